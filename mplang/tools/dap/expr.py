"""Expressions of `mpc dap`: conditional breakpoints, `evaluate`, watches and hovers.

An expression is written as in a `.mp` program: variables by their declared names or
device names (`rows_done`, `VAR12`, `bVAR3`), an axis's counters (`X.LP`, `X.EP`, `X.CV`),
integers, `+ - * / & |` with the device's
arithmetic (C division, 32-bit wrap: `mplang.ir.fold.apply_operator`), comparisons
`== != < <= > >=`, `and`/`or`/`not` (also `&&`, `||`, `!`) and parentheses. Comparisons give
1 or 0. Python's own parser reads it and only those node kinds are allowed, so an expression
can never run anything else.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable

from mplang.ir.fold import apply_operator

MAX_LENGTH = 1000  # an expression typed by a user; anything longer is refused unread
_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.FloorDiv: "/",
           ast.BitAnd: "&", ast.BitOr: "|"}
_COMPARE: dict[type[ast.cmpop], Callable[[int, int], bool]] = {
    ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b,
    ast.Lt: lambda a, b: a < b, ast.LtE: lambda a, b: a <= b,
    ast.Gt: lambda a, b: a > b, ast.GtE: lambda a, b: a >= b}
_C_LOGIC = ((re.compile(r"&&"), " and "), (re.compile(r"\|\|"), " or "),
            (re.compile(r"!(?!=)"), " not "))

Lookup = Callable[[str], "int | None"]


class ExpressionError(ValueError):
    """An expression that cannot be read or evaluated; the message says where and why."""


def parse(text: str) -> ast.expr:
    """The expression's tree, checked for allowed node kinds only (names are looked up
    when it is evaluated)."""
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the expression is longer than {MAX_LENGTH} characters")
    source = text.strip()
    for pattern, word in _C_LOGIC:
        source = pattern.sub(word, source)
    source = source.strip()
    if not source:
        raise ExpressionError("the expression is empty")
    try:
        tree = ast.parse(source, mode="eval").body
    except SyntaxError as exc:
        column = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(f"cannot read {text.strip()!r}{column}: {exc.msg}") from None
    except (ValueError, RecursionError, MemoryError) as exc:  # NUL bytes, deep nesting
        raise ExpressionError(f"cannot read {text.strip()[:80]!r}: {exc}") from None
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and not isinstance(node.value, ast.Name):
            raise ExpressionError(f"{ast.unparse(node)!r}: a dotted name is an axis and its "
                                  "counter, such as X.LP")
        if not isinstance(node, (ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.Name,
                                 ast.Attribute, ast.Constant, ast.Load, ast.operator,
                                 ast.unaryop, ast.boolop, ast.cmpop)):
            raise ExpressionError(f"{ast.unparse(node)!r} is not a variable, a number or an "
                                  "operator of an expression")
        if isinstance(node, ast.BinOp) and type(node.op) not in _BINARY:
            raise ExpressionError(f"operator {ast.unparse(node)!r}: use + - * / & |")
        if isinstance(node, ast.Compare) and any(type(op) not in _COMPARE
                                                 for op in node.ops):
            raise ExpressionError(f"comparison {ast.unparse(node)!r}: use == != < <= > >=")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Invert):
            raise ExpressionError("operator ~ is not one of the device's")
        if isinstance(node, ast.Constant) and (not isinstance(node.value, int)
                                               or isinstance(node.value, bool)):
            raise ExpressionError(f"{node.value!r} is not an integer")
    return tree


def names(tree: ast.expr) -> list[str]:
    """The variable names an expression reads, in order (`X.LP` as one name)."""
    inner = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Attribute)}
    return [_name(node) for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) or (isinstance(node, ast.Name)
                                                   and id(node) not in inner)]


def _name(node: ast.Name | ast.Attribute) -> str:
    if isinstance(node, ast.Attribute):
        assert isinstance(node.value, ast.Name)  # `parse` allows `name.name` only
        return f"{node.value.id}.{node.attr}"
    return node.id


def evaluate(tree: ast.expr, lookup: Lookup) -> int:
    """The expression's value now; ExpressionError for an unknown name or a division by
    zero."""
    try:
        return _value(tree, lookup)
    except RecursionError:
        raise ExpressionError("the expression is nested too deeply") from None


def _value(tree: ast.expr, lookup: Lookup) -> int:
    if isinstance(tree, ast.Constant):
        assert isinstance(tree.value, int)  # `parse` allows integers only
        return tree.value
    if isinstance(tree, (ast.Name, ast.Attribute)):
        name = _name(tree)
        value = lookup(name)
        if value is None:
            raise ExpressionError(f"no variable {name!r} in this build (a declared VAR or "
                                  "ALIAS name, VARn, or an axis's X.LP, X.EP, X.CV)")
        return value
    if isinstance(tree, ast.UnaryOp):
        operand = _value(tree.operand, lookup)
        if isinstance(tree.op, ast.Not):
            return int(not operand)
        return -operand if isinstance(tree.op, ast.USub) else operand
    if isinstance(tree, ast.BoolOp):
        values = (_value(value, lookup) for value in tree.values)
        if isinstance(tree.op, ast.And):
            return int(all(values))
        return int(any(values))
    if isinstance(tree, ast.Compare):
        left = _value(tree.left, lookup)
        for op, right_tree in zip(tree.ops, tree.comparators, strict=True):
            right = _value(right_tree, lookup)
            if not _COMPARE[type(op)](left, right):
                return 0
            left = right
        return 1
    assert isinstance(tree, ast.BinOp)
    left, right = _value(tree.left, lookup), _value(tree.right, lookup)
    try:
        return apply_operator(_BINARY[type(tree.op)], left, right)
    except ZeroDivisionError:
        raise ExpressionError(f"division by zero in {ast.unparse(tree)!r}") from None
