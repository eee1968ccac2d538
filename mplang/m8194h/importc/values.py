"""What a C argument or constant means: the constants the file defined so far, the integer a
constant C expression has with the vendor header's names, the operand a macro argument gives,
and the mplang spelling worth keeping (a CONST name, hex as written).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mplang.ir.catalogue import Param, Profile
from mplang.ir.macro import BVarRef, Operand, VarRef
from mplang.m8194h.importc.expressions import (
    CBin,
    CCall,
    CExpr,
    CName,
    CNum,
    CStr,
    CUnary,
    Unconvertible,
    c_binary,
    parse_expression,
)
from mplang.m8194h.importc.reader import Token

VAR_NAME = re.compile(r"VAR(\d+)", re.IGNORECASE)
BVAR_NAME = re.compile(r"bVAR(\d+)", re.IGNORECASE)
PROGRAM_NAME = re.compile(r"(MP|ISR)(\d+)")
LABEL_NAME = re.compile(r"LABEL([0-3])")
LITERAL_KINDS = frozenset({"int", "enum", "bvar"})
"""Parameter kinds whose numbers keep the C spelling (hex stays hex); axes, programs,
labels and operators are spelled by name."""


@dataclass
class Constant:
    """A `#define` or `const` the file gave a value."""

    value: int | VarRef
    spelled: str | None  # the CONST / ALIAS name when one was written, else None


class Values:
    """The constants of one C file, and how its arguments read with them."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.constants: dict[str, Constant] = {}

    def argument(self, param: Param, tokens: list[Token]) -> tuple[Operand, str | None]:
        """One C argument as an operand, with a spelling to keep (a CONST name) or None."""
        expr = parse_expression(tokens)
        if isinstance(expr, CName):
            constant = self.constants.get(expr.name)
            if constant is not None:
                return constant.value, constant.spelled
            var = VAR_NAME.fullmatch(expr.name)
            if var:
                return VarRef(int(var.group(1))), None
            bvar = BVAR_NAME.fullmatch(expr.name)
            if bvar:
                return BVarRef(int(bvar.group(1))), None
        if isinstance(expr, CStr):
            table = {"cmp_op": self.profile.cmp_ops, "calc_op": self.profile.calc_ops}.get(
                param.kind)
            if table is None or expr.value not in table:
                raise Unconvertible("a string is not a value here")
            return table[expr.value], None
        value = self.evaluate(expr, param)
        if param.kind in LITERAL_KINDS:
            if isinstance(expr, CNum):
                return value, expr.text
            if isinstance(expr, CName) and expr.name.upper() in param.symbols:
                return value, expr.name.upper()
        return value, self.spell(expr) if param.kind == "int" else None

    def evaluate(self, expr: CExpr, param: Param | None) -> int:
        """The integer a constant C expression has, with the vendor header's names."""
        if isinstance(expr, CNum):
            if isinstance(expr.value, float):
                raise Unconvertible(f"{expr.text} is not an integer")
            return expr.value
        if isinstance(expr, CName):
            return self.name_value(expr.name, param)
        if isinstance(expr, CUnary):
            inner = self.evaluate(expr.operand, param)
            return {"-": -inner, "+": inner, "~": ~inner, "!": int(not inner)}[expr.op]
        if isinstance(expr, CBin):
            return c_binary(expr.op, self.evaluate(expr.left, param),
                             self.evaluate(expr.right, param))
        if isinstance(expr, CCall):
            raise Unconvertible(f"the value of {expr.name}(...) is only known at run time")
        raise Unconvertible("a string is not a number")

    def name_value(self, name: str, param: Param | None) -> int:
        constant = self.constants.get(name)
        if constant is not None:
            if isinstance(constant.value, VarRef):
                raise Unconvertible(f"{name} is the variable VAR{constant.value.index}, not a "
                                    "number")
            return constant.value
        upper = name.upper()
        if param is not None:
            if upper in param.symbols:
                return param.symbols[upper]
            if param.kind == "cmp_op" and upper in self.profile.cmp_symbols:
                return self.profile.cmp_ops[self.profile.cmp_symbols[upper]]
        if upper.startswith(("AXIS_", "INITIAL_")):
            code = self.profile.axis_code(upper)
            if code is not None:
                return code
        program = PROGRAM_NAME.fullmatch(name)
        if program:
            wanted = (param.kind if param is not None else "").removesuffix("_or_none")
            if wanted in ("mp", "isr") and program.group(1).lower() != wanted:
                raise Unconvertible(f"{name} is not an {wanted.upper()} number")
            return int(program.group(2))
        label = LABEL_NAME.fullmatch(name)
        if label:
            return int(label.group(1))
        if VAR_NAME.fullmatch(name) or BVAR_NAME.fullmatch(name):
            raise Unconvertible(f"{name} inside an expression: a variable is passed alone")
        raise Unconvertible(f"{name} is not a constant the importer knows (a C variable? its "
                            "value is only known at run time)")

    def spell(self, expr: CExpr) -> str | None:
        """The expression in mplang syntax, if it only uses what a CONST expression may
        (numbers, CONSTs written by this import, + - * / & | and brackets)."""
        if isinstance(expr, CNum):
            return expr.text if isinstance(expr.value, int) else None
        if isinstance(expr, CName):
            constant = self.constants.get(expr.name)
            if constant is not None and constant.spelled and not isinstance(constant.value,
                                                                             VarRef):
                return constant.spelled
            return None
        if isinstance(expr, CUnary) and expr.op in "-+":
            inner = self.spell(expr.operand)
            if inner is None:
                return None
            inner = inner if _atomic(expr.operand) else f"({inner})"
            return f"-{inner}" if expr.op == "-" else inner
        if isinstance(expr, CBin) and expr.op in ("+", "-", "*", "/", "&", "|"):
            left, right = self.spell(expr.left), self.spell(expr.right)
            if left is None or right is None:
                return None
            left = left if _atomic(expr.left) else f"({left})"
            right = right if _atomic(expr.right) else f"({right})"
            return f"{left} {expr.op} {right}"
        return None


def _atomic(expr: CExpr) -> bool:
    """Needs no brackets as an operand: a number, a name, or a sign in front of one (unary
    minus binds tighter than any binary operator, in C and in mplang)."""
    if isinstance(expr, CUnary):
        return expr.op in "-+" and _atomic(expr.operand)
    return isinstance(expr, CNum | CName)
