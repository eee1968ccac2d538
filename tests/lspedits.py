"""A client's side of incremental sync, for the tests: random edits of a text, each sent as
the range an editor would send (lines ended by CRLF, LF or CR; characters in UTF-16 code
units, or the encoding the server chose), written without the server's code so that the two
can disagree."""

from __future__ import annotations

import random
import re

ALPHABET = ["a", "Z", " ", "1", "=", "\n", "\r\n", "\r", "é", "😀", "\x0c", "\u2028", "#"]
"""What edits insert: plain text, every line break, a character outside the BMP (two UTF-16
units), and characters `str.splitlines` takes for line breaks and the protocol does not."""

_BREAK = re.compile(r"\r\n|\n|\r")


_CODECS = {"utf-8": ("utf-8", 1), "utf-16": ("utf-16-le", 2), "utf-32": ("utf-32-le", 4)}


def position(text: str, offset: int, encoding: str = "utf-16") -> tuple[int, int]:
    """The (line, character) of a code-point offset, as a client counts it in `encoding`."""
    line = 0
    start = 0
    for match in _BREAK.finditer(text):
        if match.end() > offset:
            break
        line, start = line + 1, match.end()
    codec, unit = _CODECS[encoding]
    return line, len(text[start:offset].encode(codec)) // unit


def _cuts(text: str) -> list[int]:
    """Offsets a client can name: every one but between the CR and LF of a CRLF."""
    return [i for i in range(len(text) + 1)
            if not (0 < i < len(text) and text[i - 1] == "\r" and text[i] == "\n")]


def random_edit(text: str, rng: random.Random, encoding: str = "utf-16"
                ) -> tuple[tuple[int, int], tuple[int, int], str, str]:
    """One edit of `text`: its start and end positions, the inserted text, and the text
    after it."""
    cuts = _cuts(text)
    first, second = sorted(rng.choice(cuts) for _ in range(2))
    inserted = "".join(rng.choice(ALPHABET) for _ in range(rng.randint(0, 6)))
    after = text[:first] + inserted + text[second:]
    return position(text, first, encoding), position(text, second, encoding), inserted, after
