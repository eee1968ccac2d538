"""The device's integer arithmetic, and a walk over expression trees.

`apply_operator` is VAR_CALCULATE as the controller computes it (C division, 32-bit wrap);
the simulator runs programs with it and constant folding (`Scope.fold`) computes with it, so
both agree with the device. `walk_expr` visits every sub-expression: folding uses it to name
what keeps a value from being constant, lowering to find the variables an expression reads.
"""

from __future__ import annotations

from collections.abc import Iterator

from mplang.lang import ast


def wrap32(value: int) -> int:
    value &= 0xFFFFFFFF
    return value - (1 << 32) if value & 0x80000000 else value


def apply_operator(op: str, left: int, right: int, wrap: bool = True) -> int:
    """VAR_CALCULATE semantics (device profile [arithmetic]): C division, 32-bit wrap.

    Constant folding passes wrap=False and wraps itself, to warn (W110) where a constant
    expression overflows: it then holds what the device would compute."""
    if op == "+":
        result = left + right
    elif op == "-":
        result = left - right
    elif op == "*":
        result = left * right
    elif op == "/":
        if right == 0:
            raise ZeroDivisionError
        quotient = abs(left) // abs(right)
        result = quotient if (left >= 0) == (right >= 0) else -quotient
    elif op == "&":
        result = left & right
    elif op == "|":
        result = left | right
    else:
        raise ValueError(op)
    return wrap32(result) if wrap else result


def walk_expr(expr: ast.Expr) -> Iterator[ast.Expr]:
    yield expr
    match expr:
        case ast.BinOp(left=left, right=right):
            yield from walk_expr(left)
            yield from walk_expr(right)
        case ast.Neg(operand=operand):
            yield from walk_expr(operand)
        case ast.Group(items=items) | ast.Call(args=items):
            for item in items:
                yield from walk_expr(item)
