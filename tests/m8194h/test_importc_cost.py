"""`mpc import` is linear in its input (issue 19 item 7): counted, never timed.

The importer once copied the rest of the file at every line start (`text[pos:].lstrip()`), split
the whole file once per blank-line candidate and re-sliced a statement for every control head,
so 10 MB of C took over a minute. These tests count the characters copied out of the C text
and the tokens copied out of a statement; bench/importc.py prints the times.
"""

from __future__ import annotations

from typing import Any, SupportsIndex

from mplang.m8194h.importc import convert, reader, tokenize


class CountingText(str):
    """A str that adds up what is copied out of it by slicing and splitting."""

    copied = 0

    def __getitem__(self, key: SupportsIndex | slice) -> str:
        piece = str.__getitem__(self, key)
        CountingText.copied += len(piece)
        return piece

    def split(self, sep: str | None = None, maxsplit: SupportsIndex = -1) -> list[str]:
        CountingText.copied += len(self)
        return str.split(self, sep, maxsplit)


class CountingTokens(list[Any]):
    """A token list that adds up the tokens its slices copy."""

    copied = 0

    def __getitem__(self, key: Any) -> Any:
        piece = list.__getitem__(self, key)
        if isinstance(key, slice):
            CountingTokens.copied += len(piece)
            return CountingTokens(piece)  # a slice of a slice counts too
        return piece


def c_file(blocks: int) -> str:
    """Directives, blank lines, comments, host code and a program, `blocks` times over."""
    block = """#define SPEED_{n} 2000
  #include "RSM8194H.h"

/* block {n} */
RSM_MP_CREATE(h, 1, MP{slot});
RSM_MACRO_SET_V(h, 1, AXIS_X, SPEED_{n});  // speed


RSM_MACRO_MP_CLOSE(h, 1);
if (x) {{ y = 1; }}
"""
    return "".join(block.format(n=n, slot=n % 100 + 1) for n in range(blocks))


def copied_while_converting(text: str) -> int:
    CountingText.copied = 0
    convert(CountingText(text))
    return CountingText.copied


def test_import_copies_a_bounded_multiple_of_its_input() -> None:
    small, large = c_file(50), c_file(400)
    per_char_small = copied_while_converting(small) / len(small)
    per_char_large = copied_while_converting(large) / len(large)
    assert per_char_large < 6, per_char_large
    # linear: eight times the text copies (about) eight times as much, not 64 times
    assert per_char_large < per_char_small * 1.5, (per_char_small, per_char_large)


def test_a_run_of_control_heads_is_walked_once() -> None:
    heads = 2000
    tokens = CountingTokens(tokenize("else " * heads + "do x = 1;"))
    CountingTokens.copied = 0
    parts = list(reader._split_control(tokens))
    assert [kind for kind, _ in parts] == ["control"] * (heads + 1) + ["statement"]
    assert CountingTokens.copied <= len(tokens), CountingTokens.copied


def test_blank_lines_and_directives_are_still_found() -> None:
    """The linear reader groups the file as before: one blank event per run of empty lines,
    directives after leading blanks, the end of a directive before its comment."""
    text = "  #define A 1 /* one */\n\n\n#define B 2\\\n  + 3\nint x;\n\n"
    kinds = [(e.kind, e.line) for e in reader.events(text)]
    assert kinds == [("directive", 1), ("blank", 4), ("directive", 4), ("statement", 6)]
    first = reader.events(text)[0]
    assert first.tokens[0].text == "#define A 1"
    assert [t.text for t in first.trailing] == ["/* one */"]
