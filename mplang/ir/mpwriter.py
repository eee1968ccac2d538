"""Macro lines spelled as `.mp` statements, shared by `mpc disasm` and `mpc import`.

Both tools hold macro lines as a catalogue command with operands (decoded from frames, or
evaluated from vendor C calls) and must write source that the compiler lowers to exactly those
lines again. A high-level form (`VAR1 = VAR2 + 3`, `IF VAR1 < 5`, `FOR 10`, `CALL name`) is
written only where the compiler turns it back into the same single line; everything else keeps
the raw command spelling (`VAR_CALCULATE 5, '+', 3, VAR1`), which the compiler maps one to one.
Expression trees (`Leaf`, `Bin`, `Query`) let the disassembler write several lines computed
through temporaries back as one expression.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.macro import BVarRef, Operand, ProgramRef, VarRef
from mplang.ir.scope import KEYWORDS

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
PRECEDENCE = {"|": 1, "&": 2, "+": 3, "-": 3, "*": 4, "/": 4}
BLOCK_OPEN = frozenset({"FOR", "IF"})
BLOCK_CLOSE = frozenset({"NEXT", "END_IF"})


# ----------------------------------------------------------------------------- expressions
@dataclass(frozen=True)
class Leaf:
    """A constant or a variable, as it is spelled."""

    text: str
    value: Operand


@dataclass(frozen=True)
class Query:
    """A value-returning read used as a value: `GET_LP(X)`."""

    text: str


@dataclass(frozen=True)
class Bin:
    op: str
    left: Expr
    right: Expr


Expr = Leaf | Query | Bin


def _precedence(expr: Expr) -> int:
    return PRECEDENCE[expr.op] if isinstance(expr, Bin) else 9


def render_expr(expr: Expr) -> str:
    """Infix text with the fewest brackets that keep the tree's shape (the grammar's operators
    are left-associative, so a right operand of equal precedence needs brackets)."""
    if isinstance(expr, Leaf | Query):
        return expr.text
    left, right = render_expr(expr.left), render_expr(expr.right)
    if _precedence(expr.left) < PRECEDENCE[expr.op]:
        left = f"({left})"
    if _precedence(expr.right) <= PRECEDENCE[expr.op]:
        right = f"({right})"
    return f"{left} {expr.op} {right}"


def is_complex(expr: Expr) -> bool:
    """What the compiler computes in steps (it folds constant trees, which never reach here)."""
    return not isinstance(expr, Leaf)


def variables_in(expr: Expr) -> set[int]:
    """VAR indices an expression reads (reads inside a query's arguments do not count: the
    compiler's own test only looks at names in the expression)."""
    if isinstance(expr, Leaf):
        return {expr.value.index} if isinstance(expr.value, VarRef) else set()
    if isinstance(expr, Query):
        return set()
    return variables_in(expr.left) | variables_in(expr.right)


# ------------------------------------------------------------------------------- writer
@dataclass
class Writer:
    """Spells operands and single macro lines. `programs` names the build's programs by
    (kind, slot) so that CALL and ISR operands can use names; `labels` (per program) names
    label numbers."""

    catalogue: Catalogue
    programs: Mapping[tuple[str, int], str] = field(default_factory=dict)
    labels: Mapping[int, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        profile = self.catalogue.profile
        self.calc_symbol = {code: op for op, code in profile.calc_ops.items()}
        self.cmp_symbol = {code: op for op, code in profile.cmp_ops.items()}

    # ------------------------------------------------------------------ operands
    def operand(self, param: Param, value: Operand, text: str | None = None) -> str:
        """How one operand is written; `text` (a CONST name, an expression) wins where the
        caller knows better than the number."""
        if text is not None:
            return text
        if isinstance(value, VarRef):
            return f"VAR{value.index}"
        if isinstance(value, BVarRef):
            return f"bVAR{value.index}"
        if isinstance(value, ProgramRef):
            if value.name is not None:
                return value.name
            return self.program(param.kind.removesuffix("_or_none"), value.slot or 0)
        if isinstance(value, float):
            return repr(value)
        kind = param.kind
        if kind.startswith("axis") and 0 < value < 16:
            return self.catalogue.profile.axis_name(value)
        if kind in ("mp", "isr") or (kind == "isr_or_none" and value != 0):
            return self.program(kind.removesuffix("_or_none"), value)
        if kind == "label" and value in self.labels:
            return self.labels[value]
        if kind == "calc_op" and value in self.calc_symbol:
            return f"'{self.calc_symbol[value]}'"
        if kind == "cmp_op" and value in self.cmp_symbol:
            return f'"{self.cmp_symbol[value]}"'
        for symbol, code in param.symbols.items():
            if code == value and kind not in ("calc_op", "cmp_op"):
                return symbol
        return str(value)

    def program(self, kind: str, slot: int) -> str:
        """`name` of a build program, else `MPn` / `ISRn`."""
        return self.programs.get((kind, slot)) or f"{kind.upper()}{slot}"

    def value(self, value: Operand, text: str | None = None, operand_of: bool = False) -> str:
        """A value (SET_VAR data, IF and FOR operands, VAR_CALCULATE inputs); a spelled
        expression gets brackets where it is the operand of an operator."""
        if text is not None:
            atomic = IDENTIFIER.fullmatch(text) or _is_number(text)
            return f"({text})" if operand_of and not atomic else text
        if isinstance(value, VarRef):
            return f"VAR{value.index}"
        return str(value)

    def leaf(self, value: Operand, text: str | None = None) -> Leaf:
        return Leaf(self.value(value, text, operand_of=True), value)

    def name(self, command: Command) -> str:
        """The mplang name when it finds this very command and is no keyword (a raw `IF`
        would parse as the statement), else the full vendor name."""
        short = command.short_name
        if self.catalogue.lookup(short) is command and short not in KEYWORDS:
            return short
        return command.name

    # ------------------------------------------------------------------ statements
    def raw(self, command: Command, operands: Sequence[Operand],
            texts: Sequence[str | None] = ()) -> str:
        """`NAME arg, arg`: the spelling the compiler maps one to one."""
        args = [self.operand(p, v, _at(texts, i))
                for i, (p, v) in enumerate(zip(command.params, operands, strict=True))]
        return self.name(command) + (" " + ", ".join(args) if args else "")

    def statement(self, command: Command, operands: Sequence[Operand],
                  texts: Sequence[str | None] = ()) -> str:
        """One macro line as the most readable statement that lowers to exactly that line."""
        short = command.short_name
        ops = tuple(operands)
        simple = {"NEXT": "NEXT", "EXIT_FOR": "EXIT FOR", "ELSE": "ELSE", "END_IF": "END IF",
                  "EXIT_MACRO": "EXIT", "MP_TERMINATE": "TERMINATE"}
        if self.catalogue.lookup(short) is not command:
            return self.raw(command, ops, texts)
        if short in simple and not ops:
            return simple[short]
        if short == "SET_VAR" and isinstance(ops[0], VarRef) and is_value(ops[1]):
            target = _at(texts, 0) or f"VAR{ops[0].index}"
            return f"{target} = {self.value(ops[1], _at(texts, 1))}"
        if short == "VAR_CALCULATE" and isinstance(ops[3], VarRef) and \
                isinstance(ops[1], int) and ops[1] in self.calc_symbol and \
                is_value(ops[0]) and is_value(ops[2]) and \
                (isinstance(ops[0], VarRef) or isinstance(ops[2], VarRef)):
            # two constants would fold into SET_VAR: such a line stays raw
            expr = Bin(self.calc_symbol[ops[1]], self.leaf(ops[0], _at(texts, 0)),
                       self.leaf(ops[2], _at(texts, 2)))
            return f"{_at(texts, 3) or f'VAR{ops[3].index}'} = {render_expr(expr)}"
        if short == "IF" and isinstance(ops[1], int) and ops[1] in self.cmp_symbol and \
                is_value(ops[0]) and is_value(ops[2]):
            return (f"IF {self.value(ops[0], _at(texts, 0))} {self.cmp_symbol[ops[1]]} "
                    f"{self.value(ops[2], _at(texts, 2))}")
        if short == "FOR" and is_value(ops[0]):
            return f"FOR {self.value(ops[0], _at(texts, 0))}"
        if short in ("LABEL", "GOTO") and isinstance(ops[0], int):
            return f"{short} {self.labels.get(ops[0], str(ops[0]))}"
        if short == "MP_CALL":
            callee = ops[0]
            if isinstance(callee, ProgramRef):
                return f"CALL {callee.name or f'MP{callee.slot}'}"
            if isinstance(callee, int):
                return f"CALL {self.program('mp', callee)}"
        return self.raw(command, ops, texts)

    def query(self, command: Command, operands: Sequence[Operand],
              texts: Sequence[str | None] = ()) -> str:
        """A read as a value: `GET_LP(X)`, `GET_ERROR` (no arguments, no brackets)."""
        if not command.params:
            return self.name(command)
        args = [self.operand(p, v, _at(texts, i))
                for i, (p, v) in enumerate(zip(command.params, operands, strict=True))]
        return f"{self.name(command)}({', '.join(args)})"


def block_role(command: Command) -> str:
    """"open" (FOR, IF), "middle" (ELSE), "close" (NEXT, END_IF) or "" for indentation."""
    short = command.short_name
    if short in BLOCK_OPEN:
        return "open"
    if short in BLOCK_CLOSE:
        return "close"
    return "middle" if short == "ELSE" else ""


def is_value(operand: Operand) -> bool:
    """A constant or a variable: what SET_VAR, VAR_CALCULATE, IF and FOR take."""
    return isinstance(operand, VarRef) or (isinstance(operand, int)
                                           and not isinstance(operand, bool))


def _is_number(text: str) -> bool:
    return re.fullmatch(r"-?(0[xX][0-9a-fA-F]+|[0-9]+)", text) is not None


def _at(texts: Sequence[str | None], index: int) -> str | None:
    return texts[index] if index < len(texts) else None
