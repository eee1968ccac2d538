"""The hand-written tokenizer (mplang/lang/tokenizer.py) against lark's own contextual lexer:
the same tokens for every program lark reads, and a failure wherever lark fails."""

from __future__ import annotations

from functools import cache

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lark import Lark, Token
from lark.exceptions import UnexpectedInput

from mplang.lang import parser
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.tokenizer import FastLexer, Refused

Seen = tuple[str, str, int | None, int | None, int | None, int | None, int | None, int | None]


@cache
def _larks() -> tuple[Lark, Lark]:
    """The grammar without a builder, once with lark's lexer and once with the tokenizer."""
    grammar = parser._grammar()
    return (Lark(grammar, parser="lalr", lexer="contextual", start="start"),
            Lark(grammar, parser="lalr", lexer=FastLexer, start="start"))


def _stream(lark: Lark, text: str) -> tuple[list[Seen], bool]:
    """Every token the parser took, with its place, and whether the whole text parsed."""
    seen: list[Seen] = []
    interactive = lark.parse_interactive(text, start="start")
    try:
        for token in interactive.iter_parse():
            seen.append(_seen(token))
        interactive.resume_parse()
    except (UnexpectedInput, Refused):
        return seen, False
    return seen, True


def _seen(token: Token) -> Seen:
    return (token.type, str(token), token.start_pos, token.line, token.column, token.end_line,
            token.end_column, token.end_pos)


def _same_stream(text: str) -> None:
    reference, fast = _larks()
    expected, parsed = _stream(reference, text)
    got, fast_parsed = _stream(fast, text)
    if parsed:
        assert fast_parsed and got == expected
    else:  # lark failed: so must the tokenizer, having given the same tokens up to there
        # (the parser's stream holds the token it refused, lark's lexer's not the one only
        # it refused)
        assert not fast_parsed
        shorter = min(len(got), len(expected))
        assert got[:shorter] == expected[:shorter]


WORDS = ["a", "X", "xy", "VAR1", "on", "ON", "call", "mp", "Mp", "isr", "for", "For_x", "next",
         "end", "if", "then", "else", "label", "goto", "terminate", "const", "alias", "var",
         "include", "init", "interrupts", "triggers", "while", "repeat", "exit", "di", "DI",
         "OFF_TO_ON", "P", "C", "D", "_x", "SET_V", "FIXED_MOVE", "x1"]
PIECES = [" ", "  ", "\t", "\n", "\r\n", "\r", ",", "=", "==", "<", "<=", ">", ">=", "!=", "!",
          "+", "-", "*", "/", "//c", "# c", "&", "|", "(", ")", "@", "0", "7", "42", "0x1F",
          "0X", "007", "'s'", '"t"', '"open', "8.0", ".", "$", "é", "ſ", "P>=C+", "D-END",
          "di 8.0", "DI8.1", "\f"]
LINES = ["MP 1", "ISR 2 tick", "END MP", "END ISR", "END IF", "END FOR", "FOR 3", "NEXT",
         "IF a > 1 THEN", "ELSE", "WHILE x < 3", "END WHILE", "REPEAT 2", "END REPEAT",
         "EXIT", "EXIT FOR", "LABEL 1", "GOTO top", "CALL MP21", "TERMINATE", "CONST N = 4",
         "ALIAS speed = VAR3", "VAR v @ VAR9", 'INCLUDE "lib.mp"', "INIT", "END INIT",
         "INTERRUPTS MP 3", "TRIGGERS", "ON X P>=C+ CALL ISR 3",
         "ON DI 8.0 OFF_TO_ON CALL cycle", "ON di8.1 ON ABORT X", "ON Y 4 HOLD",
         "SET_V X, -2000", "x = -(a + 2) * F(b, 3) / 4 & 7 | 1", "FIXED_MOVE(XY, 10, -5)"]


@st.composite
def programs(draw: st.DrawFn) -> str:
    """Lines of the grammar's statement forms, runs of its pieces, and the two mixed."""
    lines = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.integers(0, 2))
        if kind == 0:
            lines.append(draw(st.sampled_from(LINES)))
        else:
            parts = draw(st.lists(st.sampled_from(WORDS + PIECES if kind == 1 else
                                                  WORDS + PIECES + LINES), max_size=8))
            lines.append(" ".join(parts) if draw(st.booleans()) else "".join(parts))
    return "\n".join(lines) + draw(st.sampled_from(["", "\n", "\r\n"]))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs())
def test_the_tokenizer_gives_lark_s_tokens(text: str) -> None:
    _same_stream(text)


@settings(max_examples=150, deadline=None)
@given(st.text(alphabet=st.sampled_from(list("aZ_09x .,=<>!+-*/&|()@#'\"\n\r\t$é")),
               max_size=40))
def test_the_tokenizer_gives_lark_s_tokens_on_any_text(text: str) -> None:
    _same_stream(text)


@pytest.mark.parametrize("text", [
    "ON X P>=C+ CALL ISR 3\n", "ON DI 8.0 OFF_TO_ON CALL cycle\n", "VAR for\n", "MP 5 next\n",
    "x == 1\n", "IF a == b THEN\n", "FOO 0x\n", "a = 1 // c\r\n# d\n", "ON X on CALL 3\n",
    "X = 1   ", "   ", "", "\t\f \n  \n", "a = 1 \t# c  \n  ", " \t\r\n",
])
def test_the_tokenizer_on_the_contextual_cases(text: str) -> None:
    """Keywords that are names where only a name fits, conditions, DI channels, `==`; blanks
    before a token, a comment, a line's end and the text's end."""
    _same_stream(text)


def test_a_text_the_tokenizer_refuses_is_parsed_by_lark_s_lexer() -> None:
    """A non-ASCII letter joined to a word: lark's lexer has the last word (here, E101)."""
    sink = DiagnosticSink()
    parser.parse_text("MP 1\nXé = 1\nEND MP\n", "t.mp", sink)
    assert [(d.code, d.span.line, d.span.col) for d in sink.sorted()] == [("E101", 2, 2)]


@pytest.mark.parametrize(("line", "found"), [
    ("X = 999999999999999999999 +", ("E108", 5)),
    ("X = 999999999999999999999 $", ("E101", 27)),
    ("X = 999999999999999999999 5", ("E101", 27)),
    ("X = 888888888888888888888 + F(1, 999999999999999999999)", ("E108", 5)),
    ("FOO (1,2), 999999999999999999999", ("E108", 12)),
    ("MP 999999999999999999999 x y", ("E101", 28)),
])
def test_a_too_long_number_is_reported_where_it_was(line: str, found: tuple[str, int]) -> None:
    """The flat expressions keep a number a rule of its own: the number is refused (E108)
    on the token after it, as before, so E108 and E101 win where they did."""
    sink = DiagnosticSink()
    parser.parse_text(line, "t.mp", sink)
    assert [(d.code, d.span.col) for d in sink.sorted()] == [found]
