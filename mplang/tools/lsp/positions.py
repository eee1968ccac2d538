"""Places in a document as an editor counts them, without pygls.

The compiler's spans are 1-based lines and columns counted in characters (code points), with an
exclusive end column. LSP positions are 0-based, and their `character` counts code units of
the encoding the client and server agreed on (UTF-16 unless negotiated otherwise). Everything
in `mplang.tools.lsp` works in 0-based code points; the server converts at the boundary with
`to_client_character` / `from_client_character`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from mplang.lang.diagnostics import Span
from mplang.lang.linecache import text_lines

ENCODINGS = ("utf-8", "utf-16", "utf-32")
_WORD = re.compile(r"[A-Za-z0-9_]+")


@dataclass(frozen=True, order=True)
class Pos:
    """0-based line and 0-based character (code points)."""

    line: int
    character: int


@dataclass(frozen=True)
class Range:
    start: Pos
    end: Pos

    def contains(self, pos: Pos) -> bool:
        """End-inclusive, so a cursor just after a word still counts as on it."""
        return self.start <= pos <= self.end


@dataclass(frozen=True)
class Location:
    path: Path
    range: Range


def split_lines(text: str) -> list[str]:
    """Lines as the compiler numbers them: split at '\\n', a trailing '\\r' dropped."""
    if "\r" not in text:  # nearly every text: split in C only, once per check
        return text_lines(text)
    return [line.removesuffix("\r") for line in text.split("\n")]


def line_range(line: int, start: int, end: int) -> Range:
    return Range(Pos(line, start), Pos(line, end))


def span_range(span: Span, lines: list[str]) -> Range:
    """The 0-based range of a compiler span.

    A span without an end column covers the word at its column, or (at column 1) the line's
    text, so that every diagnostic underlines something visible. Lines past the end of the
    text are clamped to the last line.
    """
    if not lines:
        return line_range(0, 0, 0)
    line = min(max(span.line, 1), len(lines)) - 1
    text = lines[line]
    start = min(max(span.col, 1) - 1, len(text))
    if span.end_col is not None:
        end = min(max(span.end_col - 1, start), len(text))
        return line_range(line, start, end)
    word = _WORD.match(text, start)
    if word and span.col > 1:
        return line_range(line, start, word.end())
    stripped = text.rstrip()
    if span.col == 1 and stripped.strip():
        return line_range(line, len(text) - len(text.lstrip()), len(stripped))
    return line_range(line, start, min(start + 1, len(text)))


def _units(char: str, encoding: str) -> int:
    if encoding == "utf-8":
        return len(char.encode("utf-8"))
    if encoding == "utf-16":
        return 2 if ord(char) > 0xFFFF else 1
    return 1


def to_client_character(line_text: str, character: int, encoding: str) -> int:
    """Code points -> the client's code units on one line (clamped to the line).

    An ASCII line (nearly every line of a program) or UTF-32 counts one unit per code point:
    no per-character walk; only a line with other characters is counted character by
    character."""
    character = min(max(character, 0), len(line_text))
    if encoding == "utf-32" or line_text.isascii():
        return character
    return sum(_units(char, encoding) for char in line_text[:character])


def from_client_character(line_text: str, units: int, encoding: str) -> int:
    """The client's code units -> code points on one line (clamped to the line; a position
    that falls inside a character's code units moves past that character). ASCII and UTF-32
    take the fast path of `to_client_character`."""
    if encoding == "utf-32" or line_text.isascii():
        return min(max(units, 0), len(line_text))
    counted = 0
    for index, char in enumerate(line_text):
        if counted >= units:
            return index
        counted += _units(char, encoding)
    return len(line_text)


_LINE_BREAK = re.compile(r"\r\n|\n|\r")


def apply_change(text: str, start: tuple[int, int], end: tuple[int, int], new_text: str,
                 encoding: str) -> str:
    """`text` with the client's range edit applied (incremental sync). Lines are the
    protocol's: ended by CRLF, LF or CR (pygls splits with `str.splitlines`, which also
    breaks at form feeds, U+2028 and the like, and so misplaces edits in such a text).
    `start`/`end` are (line, character) in the client's code units; a character past its
    line's end means the line's end, a line past the last the end of the text."""
    begin, finish = _offset(text, start, encoding), _offset(text, end, encoding)
    finish = max(begin, finish)
    return text[:begin] + new_text + text[finish:]


def _offset(text: str, position: tuple[int, int], encoding: str) -> int:
    line, units = position
    if line < 0:
        return 0
    first = _line_start(text, line)
    if first is None:
        return len(text)
    ending = _LINE_BREAK.search(text, first)
    line_text = text[first:ending.start() if ending else len(text)]
    return first + from_client_character(line_text, max(units, 0), encoding)


def _line_start(text: str, line: int) -> int | None:
    """Where a line (0-based) starts in `text`, None past its last line. A text without CR
    (the common case) is cut by `str.split` at C speed; only one with CRs is scanned for
    its breaks, up to that line."""
    if line == 0:
        return 0
    if "\r" not in text:
        parts = text.split("\n", line)
        return len(text) - len(parts[line]) if len(parts) > line else None
    for count, found in enumerate(_LINE_BREAK.finditer(text), start=1):
        if count == line:
            return found.end()
    return None
