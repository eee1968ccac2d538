"""The hand-written tokenizer that feeds lark (a custom lexer class, lark's interface 2).

Lark's own contextual lexer tries, at every token, one large regular expression built for
the parser state it is in; this one reads each token's shape with one small expression and
decides what the grammar's terminal is from the set of terminals the parser accepts in
that state, the way the contextual lexer chooses, so the two give the same tokens
(tests/lang/test_tokenizer.py compares them on generated programs). What it is fast for is
text the parser accepts: anything unusual (a character outside the grammar's, a non-ASCII
letter next to a word) raises `Refused`, and `mplang.lang.parser` parses that text again
with lark's own lexer, which also writes the syntax diagnostics. So only the fast path lives
here; every message stays where it was.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

from lark import Token
from lark.lexer import Lexer, LexerState

# One expression for the shape of the next token, the blanks before it taken with it; the
# group says which. Keywords, names, interrupt conditions and DI channels all start as a
# `word`: the state decides. Blanks up to the end of the text are `end`.
_SHAPE = re.compile(r"""
    [ \t\f]*
    (?:(?P<end>\Z)
  | (?P<comment>(?:\#|//)[^\n]*)
  | (?P<newline>\r?\n)
  | (?P<int>0[xX][0-9a-fA-F]+|[0-9]+)
  | (?P<word>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<string>"[^"\n]*"|'[^'\n]*')
  | (?P<cmp><=|>=|==|!=)
  | (?P<char>[<>=|&+\-*/()@,]))
""", re.VERBOSE)

_CHAR_TERMINALS = {"<": "CMP", ">": "CMP", "=": "EQUAL", "|": "BAR", "&": "AMP", "+": "PLUS",
                   "-": "MINUS", "*": "STAR", "/": "SLASH", "(": "LPAR", ")": "RPAR",
                   "@": "AT", ",": "COMMA"}
KEYWORDS = frozenset({
    "CONST", "ALIAS", "VAR", "INCLUDE", "MP", "ISR", "END", "FOR", "WHILE", "REPEAT", "NEXT",
    "EXIT", "IF", "THEN", "ELSE", "LABEL", "GOTO", "CALL", "TERMINATE", "INIT", "INTERRUPTS",
    "TRIGGERS", "ON",
})
_DI_PIN = re.compile(r"di[ \t]*[0-9]+\.[0-9]+", re.IGNORECASE)
_CONDITION = re.compile(r"[A-Za-z][A-Za-z0-9_<>=+\-]*")


class Refused(Exception):
    """The text holds something this tokenizer leaves to lark's own lexer."""


class FastLexer(Lexer):
    """Tokens for lark's LALR parser, chosen by the terminals its current state accepts."""

    __future_interface__ = 2

    def __init__(self, conf: Any) -> None:
        self.accepts: dict[int, frozenset[str]] = {}

    def _accepted(self, position: int, parser_state: Any) -> frozenset[str]:
        """The terminals the parser can take in state `position` (what lark's contextual
        lexer builds its expression of for that state)."""
        found = frozenset(name for name in parser_state.parse_conf.states[position]
                          if name.isupper())
        self.accepts[position] = found
        return found

    def lex(self, lexer_state: LexerState, parser_state: Any) -> Iterator[Token]:
        """Lark's interface: yield tokens while the parser consumes them (the state read for
        a word is the one after the previous token was shifted, as lark's lexer reads it).

        Only a word and `==` need the state: any other token the state does not take makes
        the parser fail on it, as lark's lexer would have failed before it."""
        text_slice = lexer_state.text
        text: str = text_slice.text
        stop: int = text_slice.end
        counter = lexer_state.line_ctr  # where an earlier call stopped (lark resumes so)
        pos: int = counter.char_pos
        line: int = counter.line
        line_start: int = counter.line_start_pos
        match_shape = _SHAPE.match
        accepts = self.accepts
        stack: list[int] = parser_state.state_stack
        new = str.__new__
        while pos < stop:
            found = match_shape(text, pos, stop)
            if found is None:
                raise Refused(f"character {text[pos]!r} at offset {pos}")
            kind: str = found.lastgroup  # type: ignore[assignment]  # every branch is named
            end = found.end()
            if kind == "comment":
                pos = end
                continue
            if kind == "end":
                counter.char_pos = end
                break
            pos = found.start(kind)  # past the blanks
            value = found.group(kind)
            if kind == "word":
                if end < stop and not text[end].isascii():
                    raise Refused("a non-ASCII character joins a word")
                state = stack[-1]
                accepted = accepts.get(state) or self._accepted(state, parser_state)
                terminal, value = self._word(text, pos, stop, value, accepted)
                end = pos + len(value)
            elif kind == "int":
                terminal = "INT"
            elif kind == "newline":
                terminal = "_NL"
            elif kind == "string":
                terminal = "STRING"
            elif kind == "cmp":
                terminal = "CMP"
                if value == "==":
                    state = stack[-1]
                    accepted = accepts.get(state) or self._accepted(state, parser_state)
                    if "CMP" not in accepted:  # `x == 1` where only `=` fits: lark's `=`
                        terminal, value, end = "EQUAL", "=", pos + 1
            else:
                terminal = _CHAR_TERMINALS[value]
            token: Token = new(Token, value)
            token.type = terminal
            token.value = value
            token.start_pos = pos
            token.line = line
            token.column = pos - line_start + 1
            token.end_pos = end
            if kind == "newline":
                line += 1
                line_start = end
                token.end_line = line
                token.end_column = 1
            else:
                token.end_line = line
                token.end_column = token.column + end - pos
            pos = counter.char_pos = end
            counter.line, counter.line_start_pos = line, line_start
            counter.column = end - line_start + 1
            yield token

    @staticmethod
    def _word(text: str, pos: int, stop: int, value: str,
              accepted: frozenset[str]) -> tuple[str, str]:
        """The terminal a word starts, in the contextual lexer's order: a DI channel, then a
        keyword, then a condition, then a name (the value can reach past the word)."""
        if "DI_PIN" in accepted and value[:2].upper() == "DI":
            pin = _DI_PIN.match(text, pos, stop)
            if pin is not None:
                return "DI_PIN", pin.group()
        upper = value.upper()
        if upper in KEYWORDS and upper in accepted:
            return upper, value
        if "CONDITION" in accepted:
            condition = _CONDITION.match(text, pos, stop)
            if condition is not None:
                return "CONDITION", condition.group()
        return "NAME", value
