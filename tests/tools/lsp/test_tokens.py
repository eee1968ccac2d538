"""Reading one line around the cursor: words, strings, comments, argument positions."""

from __future__ import annotations

import pytest

from mplang.tools.lsp.tokens import ArgumentSlot, cursor_at, lex_line


def test_lexer_follows_the_grammars_terminals() -> None:
    tokens = lex_line('  VAR1 = 0x1F + count # note "x"')
    assert [(t.kind, t.text) for t in tokens] == [
        ("name", "VAR1"), ("op", "="), ("int", "0x1F"), ("op", "+"), ("name", "count"),
        ("comment", '# note "x"')]
    assert tokens[0].start == 2 and tokens[0].end == 6
    assert [t.kind for t in lex_line("IF a <= b // c")] == ["name", "name", "op", "name",
                                                             "comment"]


def test_unterminated_string_runs_to_the_end_of_the_line() -> None:
    (_keyword, string) = lex_line('INCLUDE "comm')
    assert string.kind == "string" and string.string_value == "comm"
    assert lex_line('INCLUDE "a.mp"')[1].string_value == "a.mp"


def test_cursor_in_a_comment_or_a_string() -> None:
    assert cursor_at("FIXED_MOVE X, 1 # mo", 20).in_comment
    assert not cursor_at("FIXED_MOVE X, 1 # mo", 15).in_comment
    assert cursor_at('INCLUDE "co', 11).string is not None
    assert cursor_at('INCLUDE "co.mp"', 15).string is None  # after the closing quote


def test_cursor_word_and_what_stands_before_it() -> None:
    cursor = cursor_at("    GOTO to", 11)
    assert cursor.head == "GOTO" and cursor.position == 1
    assert cursor.word is not None and cursor.word.text == "to"
    blank = cursor_at("    ", 4)
    assert blank.word is None and blank.position == 0 and blank.head == ""


@pytest.mark.parametrize(("line", "expected"), [
    ("FIXED_MOVE ", ArgumentSlot("FIXED_MOVE", 0)),
    ("FIXED_MOVE X, ", ArgumentSlot("FIXED_MOVE", 1)),
    ("FIXED_MOVE X, PIT", ArgumentSlot("FIXED_MOVE", 1)),
    ("FIXED_MOVE(X, ", ArgumentSlot("FIXED_MOVE", 1)),
    ("FIXED_MOVE X, (A + ", ArgumentSlot("FIXED_MOVE", 1)),
    ("VAR1 = GET_LP(", ArgumentSlot("GET_LP", 0)),
    ("VAR1 = FRNET_READ(8, ", ArgumentSlot("FRNET_READ", 1)),
    ("VAR1 = GET_LP(X) + ", None),
    ("VAR1 = ", None),
    ("IF VAR1 > ", None),
    ("FOR (", None),
    ("", None),
])
def test_argument_slot(line: str, expected: ArgumentSlot | None) -> None:
    assert cursor_at(line, len(line)).argument() == expected
