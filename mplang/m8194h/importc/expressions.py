"""Constant C expressions (an argument, a `#define` value): parsed by precedence climbing into a
small tree (`CExpr`) and folded with C's integer arithmetic. `Unconvertible` is what the
importer raises for anything it cannot turn into `.mp`.
"""

from __future__ import annotations

import codecs
import re
from dataclasses import dataclass

from mplang.m8194h.importc.reader import TYPE_WORDS, Token, matching


class Unconvertible(Exception):
    """Something the importer cannot turn into `.mp`; the message says what and why."""


@dataclass(frozen=True)
class CNum:
    value: int | float
    text: str


@dataclass(frozen=True)
class CStr:
    value: str


@dataclass(frozen=True)
class CName:
    name: str


@dataclass(frozen=True)
class CUnary:
    op: str
    operand: CExpr


@dataclass(frozen=True)
class CBin:
    op: str
    left: CExpr
    right: CExpr


@dataclass(frozen=True)
class CCall:
    name: str


CExpr = CNum | CStr | CName | CUnary | CBin | CCall
BINARY = [("||",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="), ("<", ">", "<=", ">="),
          ("<<", ">>"), ("+", "-"), ("*", "/", "%")]


class _Parser:
    """Precedence climbing over the tokens of one C expression (an argument, a #define)."""

    def __init__(self, tokens: list[Token]) -> None:
        self.tokens = tokens
        self.pos = 0

    def peek(self) -> Token | None:
        return self.tokens[self.pos] if self.pos < len(self.tokens) else None

    def next(self) -> Token:
        token = self.peek()
        if token is None:
            raise Unconvertible("incomplete expression")
        self.pos += 1
        return token

    def parse(self) -> CExpr:
        expr = self.binary(0)
        if self.peek() is not None:
            raise Unconvertible(f"unexpected {self.peek().text!r}")  # type: ignore[union-attr]
        return expr

    def binary(self, level: int) -> CExpr:
        if level == len(BINARY):
            return self.unary()
        left = self.binary(level + 1)
        while (token := self.peek()) is not None and token.kind == "punct" and \
                token.text in BINARY[level]:
            self.pos += 1
            left = CBin(token.text, left, self.binary(level + 1))
        return left

    def unary(self) -> CExpr:
        token = self.next()
        if token.kind == "punct" and token.text in ("-", "+", "~", "!"):
            return CUnary(token.text, self.unary())
        if token.text == "(" and self._is_cast():
            while self.next().text != ")":
                pass
            return self.unary()
        if token.text == "(":
            inner = self.binary(0)
            if self.next().text != ")":
                raise Unconvertible("unbalanced brackets")
            return inner
        if token.kind == "number":
            return _number(token.text)
        if token.kind == "char":
            return CNum(_char_value(token.text), token.text)
        if token.kind == "string":
            value = _unquote(token.text)
            while (more := self.peek()) is not None and more.kind == "string":
                self.pos += 1
                value += _unquote(more.text)
            return CStr(value)
        if token.kind == "ident":
            following = self.peek()
            if following is not None and following.text == "(":
                self.pos = matching(self.tokens, self.pos) + 1
                return CCall(token.text)
            return CName(token.text)
        raise Unconvertible(f"unexpected {token.text!r}")

    def _is_cast(self) -> bool:
        index = self.pos
        words = 0
        while index < len(self.tokens) and self.tokens[index].text != ")":
            token = self.tokens[index]
            if not (token.text in TYPE_WORDS or token.text == "*"):
                return False
            words += 1
            index += 1
        return words > 0 and index < len(self.tokens)


def parse_expression(tokens: list[Token]) -> CExpr:
    if not tokens:
        raise Unconvertible("empty argument")
    return _Parser(tokens).parse()


def _number(text: str) -> CNum:
    """A C number: suffixes dropped, octal and binary as decimal, hex kept as written."""
    lowered = text.lower()
    if lowered.startswith("0x"):
        spelled = text.rstrip("uUlL")
        return CNum(int(spelled, 16), spelled)
    digits = lowered.rstrip("ul")
    try:
        if digits.startswith("0b"):
            return CNum(int(digits, 2), str(int(digits, 2)))
        if re.fullmatch(r"[0-9]+", digits):
            value = int(digits, 8) if len(digits) > 1 and digits.startswith("0") else \
                int(digits)
            return CNum(value, str(value))
        return CNum(float(lowered.rstrip("f")), text)
    except ValueError:
        raise Unconvertible(f"{text} is not a C number") from None


def _unquote(text: str) -> str:
    return codecs.decode(text[1:-1], "unicode_escape")


def _char_value(text: str) -> int:
    value = _unquote(text)
    if len(value) != 1:
        raise Unconvertible(f"character constant {text} is not one character")
    return ord(value)


def _c_divide(left: int, right: int) -> int:
    if right == 0:
        raise Unconvertible("division by zero")
    quotient = abs(left) // abs(right)
    return quotient if (left >= 0) == (right >= 0) else -quotient


def c_binary(op: str, left: int, right: int) -> int:
    if op == "/":
        return _c_divide(left, right)
    if op == "%":
        return left - _c_divide(left, right) * right
    table = {
        "+": lambda: left + right, "-": lambda: left - right, "*": lambda: left * right,
        "&": lambda: left & right, "|": lambda: left | right, "^": lambda: left ^ right,
        "<<": lambda: left << right if 0 <= right < 64 else 0,
        ">>": lambda: left >> right if 0 <= right < 64 else 0,
        "==": lambda: int(left == right), "!=": lambda: int(left != right),
        "<": lambda: int(left < right), ">": lambda: int(left > right),
        "<=": lambda: int(left <= right), ">=": lambda: int(left >= right),
        "&&": lambda: int(bool(left) and bool(right)),
        "||": lambda: int(bool(left) or bool(right)),
    }
    return table[op]()
