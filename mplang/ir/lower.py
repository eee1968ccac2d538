"""AST -> macro lines, with the checks that need names, types and block context.

One `ProgramLowerer` walks one program. Names are resolved against the build's CONSTs and
ALIASes, command arguments are checked against the catalogue's parameter descriptions, and
expressions are lowered through a pool of compiler temporaries into SET_VAR/VAR_CALCULATE
lines. Every problem is reported with its code and the walk goes on.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterator
from dataclasses import dataclass, field

from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.macro import (
    BVarRef,
    CallSite,
    LoweredProgram,
    MacroLine,
    Operand,
    ProgramRef,
    VarRef,
)
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span

VAR_RE = re.compile(r"VAR(\d+)", re.IGNORECASE)
BVAR_RE = re.compile(r"BVAR(\d+)", re.IGNORECASE)
PROGRAM_RE = re.compile(r"(MP|ISR)(\d+)", re.IGNORECASE)
KEYWORDS = {"CONST", "ALIAS", "VAR", "WHILE", "REPEAT", "INCLUDE", "MP", "ISR", "END", "FOR",
            "NEXT", "EXIT", "IF", "THEN", "ELSE", "LABEL", "GOTO", "CALL", "TERMINATE",
            "INIT", "INTERRUPTS", "TRIGGERS", "ON"}
CONTROL_COMMANDS = {"SET_VAR", "VAR_CALCULATE"}


def wrap32(value: int) -> int:
    value &= 0xFFFFFFFF
    return value - (1 << 32) if value & 0x80000000 else value


def apply_operator(op: str, left: int, right: int, wrap: bool = True) -> int:
    """VAR_CALCULATE semantics (device profile [arithmetic]): C division, 32-bit wrap.

    Constant folding passes wrap=False: a constant that overflows is the author's mistake,
    reported by the range check, not silently wrapped."""
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


class ConstError(Exception):
    """A constant that cannot be evaluated. code "" marks a follow-on of an error already
    reported (a CONST whose own definition failed), which is not reported again."""

    def __init__(self, span: Span, message: str, code: str = "E206") -> None:
        super().__init__(message)
        self.span = span
        self.message = message
        self.code = code


DEFAULT_VAR_POOL = range(400, 500)


@dataclass(frozen=True)
class Variable:
    """A `VAR name` declaration as placed: the host finds it at holding register 300 + 2n."""

    name: str
    index: int
    pinned: bool
    span: Span


@dataclass
class Scope:
    """Build-wide names: constants (evaluated lazily, cycles reported), aliases, and the
    declared variables (`VAR name [@ VARn]`), which become aliases once placed."""

    catalogue: Catalogue
    sink: DiagnosticSink
    var_pool: range = DEFAULT_VAR_POOL
    temps: range = range(0)
    const_exprs: dict[str, ast.Const] = field(default_factory=dict)
    const_values: dict[str, int | None] = field(default_factory=dict)
    aliases: dict[str, int] = field(default_factory=dict)
    alias_spans: dict[str, Span] = field(default_factory=dict)
    variables: list[Variable] = field(default_factory=list)
    declared_indices: set[int] = field(default_factory=set)
    _evaluating: set[str] = field(default_factory=set)

    @classmethod
    def declared(cls, unit: ast.Unit, catalogue: Catalogue, sink: DiagnosticSink,
                 var_pool: range = DEFAULT_VAR_POOL, temps: range = range(0)) -> Scope:
        """The build's names, declared; a constant that cannot be evaluated is reported to
        `sink` (every lowering of a unit starts here)."""
        scope = cls(catalogue, sink, var_pool, temps)
        try:
            scope.declare(unit)
        except ConstError as err:
            if err.code:
                sink.add(err.code, err.span, err.message)
        return scope

    def reserved(self, name: str) -> str | None:
        upper = name.upper()
        profile = self.catalogue.profile
        if upper in KEYWORDS:
            return "a keyword"
        if VAR_RE.fullmatch(upper) or BVAR_RE.fullmatch(upper):
            return "a variable name"
        if PROGRAM_RE.fullmatch(upper):
            return "a program name"
        if profile.axis_code(upper) is not None:
            return "an axis name"
        if self.catalogue.lookup(upper) is not None:
            return "a command name"
        if upper in profile.cmp_symbols:
            return "a comparison constant"
        return None

    def _variable_index(self, text: str, span: Span, what: str) -> int | None:
        """The n of a VARn operand of ALIAS / VAR @, checked (None, reported, if bad)."""
        match = VAR_RE.fullmatch(text)
        if not match:
            self.sink.add("E207", span, f"{what} must name a variable VARn, not {text!r}")
            return None
        index = int(match.group(1))
        if index >= self.catalogue.profile.var("count"):
            last = self.catalogue.profile.var("count") - 1
            self.sink.add("E204", span, f"{text} does not exist: variables are VAR0..VAR{last}")
            return None
        return index

    def declare(self, unit: ast.Unit) -> None:
        seen: dict[str, Span] = {}
        decls: list[ast.Const | ast.Alias | ast.VarDecl] = [*unit.consts, *unit.aliases,
                                                             *unit.variables]
        pinned: dict[int, ast.VarDecl] = {}
        unplaced: list[ast.VarDecl] = []
        for decl in decls:
            key = decl.name.upper()
            why = self.reserved(decl.name)
            if why:
                self.sink.add("E205", decl.name_span, f"{decl.name!r} is {why} and cannot be "
                              "redefined")
                continue
            if key in seen:
                self.sink.add("E203", decl.name_span, f"{decl.name!r} is already defined",
                              related=((seen[key], "first definition"),))
                continue
            seen[key] = decl.name_span
            if isinstance(decl, ast.Const):
                self.const_exprs[key] = decl
            elif isinstance(decl, ast.Alias):
                index = self._variable_index(decl.target, decl.target_span,
                                             f"ALIAS {decl.name}")
                if index is not None:
                    self.aliases[key] = index
                    self.alias_spans[key] = decl.name_span
            elif decl.pin is None:
                unplaced.append(decl)
            else:
                assert decl.pin_span is not None
                index = self._variable_index(decl.pin, decl.pin_span, f"VAR {decl.name} @")
                if index is None:
                    continue
                if index in pinned:
                    other = pinned[index]
                    self.sink.add("E209", decl.pin_span, f"VAR {decl.name} and VAR "
                                  f"{other.name} are both pinned to VAR{index}",
                                  related=((other.name_span, f"{other.name} is pinned here"),),
                                  hint="pin each variable to its own VARn, or use ALIAS for a "
                                  "second name of the same variable")
                    self.aliases[key] = index  # no follow-on "unknown name" errors
                    continue
                if index in self.temps:
                    self.sink.add("W104", decl.pin_span, f"VAR{index} is in the pool of "
                                  "expression temporaries: its value changes behind your back",
                                  hint="pin it elsewhere, or move the pool with --temp-vars")
                pinned[index] = decl
                self._place(decl, index, pinned=True)
        if unplaced:
            self._allocate(unit, unplaced)
        for key in self.const_exprs:
            try:
                self.const(key)
            except RecursionError:
                decl = self.const_exprs[key]
                self.const_values[key] = None
                self.sink.add("E107", decl.name_span, f"CONST {decl.name} is nested too "
                              "deeply to compute", hint="split it into several CONSTs")

    def _place(self, decl: ast.VarDecl, index: int, pinned: bool) -> None:
        key = decl.name.upper()
        self.aliases[key] = index
        self.alias_spans[key] = decl.name_span
        self.variables.append(Variable(decl.name, index, pinned, decl.name_span))
        self.declared_indices.add(index)

    def _allocate(self, unit: ast.Unit, unplaced: list[ast.VarDecl]) -> None:
        """Unpinned variables get the lowest free VARn of the pool, in declaration order:
        free means named by nothing in the build (VARn, ALIAS, a pin) and not a temporary."""
        used = set(self.aliases.values()) | _named_variables(unit)
        free = (n for n in self.var_pool if n not in used and n not in self.temps)
        for decl in unplaced:
            index = next(free, None)
            if index is None:
                first, last = self.var_pool.start, self.var_pool.stop - 1
                self.sink.add("E208", decl.name_span, f"no free variable left for VAR "
                              f"{decl.name}: the pool VAR{first}..VAR{last} is used up",
                              hint="widen var-pool in mpc.toml, or pin some variables "
                              "with VAR name @ VARn")
                # the build has failed; naming some VAR avoids "unknown name" follow-ons
                self.aliases[decl.name.upper()] = self.var_pool.start
                continue
            self._place(decl, index, pinned=False)

    def const(self, key: str) -> int | None:
        """Value of a CONST (None if it could not be evaluated; reported once)."""
        if key in self.const_values:
            return self.const_values[key]
        decl = self.const_exprs[key]
        if key in self._evaluating:
            raise ConstError(decl.name_span, f"CONST {decl.name} is defined in terms of itself")
        self._evaluating.add(key)
        try:
            value: int | None = self.fold(decl.value)
            if value is None:
                self._not_constant(decl)
        except ConstError as err:
            if err.code:
                self.sink.add(err.code, err.span, err.message)
            value = None
        finally:
            self._evaluating.discard(key)
        self.const_values[key] = value
        return value

    def _not_constant(self, decl: ast.Const) -> None:
        """E206, naming the first name that keeps the value from being a constant."""
        hint = "CONST values may use numbers, other CONSTs and + - * / & | ( )"
        culprit = next((e for e in _walk(decl.value) if isinstance(e, ast.Call) or (
            isinstance(e, ast.Name) and e.name.upper() not in self.const_exprs)), None)
        if isinstance(culprit, ast.Call):
            self.sink.add("E206", culprit.span, f"CONST {decl.name} uses {culprit.name}(...), "
                          "which is read at run time, so it is not a constant",
                          hint="assign it to a variable in a program instead")
            return
        if not isinstance(culprit, ast.Name):
            self.sink.add("E206", decl.value.span, f"CONST {decl.name} is not a constant "
                          "expression", hint=hint)
            return
        what = "a variable" if self.variable(culprit.name) is not None else \
            self.reserved(culprit.name) or "not defined"
        self.sink.add("E206", culprit.span, f"CONST {decl.name} uses {culprit.name}, which is "
                      f"{what}, so it is not a constant",
                      hint=did_you_mean(culprit.name, list(self.const_exprs)) or hint)

    def fold(self, expr: ast.Expr) -> int | None:
        """Integer value of a constant expression, None if it involves run-time values."""
        match expr:
            case ast.Num(value=value):
                return value
            case ast.Name(name=name):
                key = name.upper()
                if key in self.const_exprs:
                    known = self.const(key)
                    if known is None:
                        raise ConstError(expr.span, f"CONST {name} has no value", code="")
                    return known
                return None
            case ast.Neg(operand=operand):
                inner = self.fold(operand)
                return None if inner is None else -inner
            case ast.Group(items=[single]):
                return self.fold(single)
            case ast.BinOp(op=op, left=left, right=right):
                a, b = self.fold(left), self.fold(right)
                if a is None or b is None:
                    return None
                try:
                    return apply_operator(op, a, b, wrap=False)
                except ZeroDivisionError:
                    raise ConstError(right.span, "division by zero in a constant "
                                     "expression") from None
        return None

    def variable(self, name: str) -> int | None:
        """Index of VARn or of an alias, None if the name is not a variable."""
        key = name.upper()
        if key in self.aliases:
            return self.aliases[key]
        match = VAR_RE.fullmatch(key)
        return int(match.group(1)) if match else None


def _named_variables(unit: ast.Unit) -> set[int]:
    """Every VARn written literally anywhere in the programs of the build."""
    found: set[int] = set()

    def visit(node: object) -> None:
        if isinstance(node, ast.Name):
            match = VAR_RE.fullmatch(node.name)
        elif isinstance(node, ast.Assign):
            match = VAR_RE.fullmatch(node.target)
        else:
            match = None
        if match:
            found.add(int(match.group(1)))
        if isinstance(node, list):
            for item in node:
                visit(item)
        elif hasattr(node, "__dataclass_fields__"):
            for name in node.__dataclass_fields__:
                value = getattr(node, name)
                if isinstance(value, list) or hasattr(value, "__dataclass_fields__"):
                    visit(value)

    for program in unit.programs:
        visit(program.body)
    return found


def did_you_mean(name: str, candidates: list[str]) -> str:
    close = difflib.get_close_matches(name.upper(), candidates, n=1, cutoff=0.6)
    return f"did you mean {close[0]}?" if close else ""


def temps_for(kind: str, temps: range) -> range:
    """The part of the temporary pool a program of `kind` computes in. An ISR runs between
    two lines of the MP it interrupts, so it must not overwrite the MP's half-computed
    temporaries: ISRs take the top quarter of the pool (at least two variables), MPs the
    rest. A pool of fewer than four variables is shared (and then an ISR must not compute
    expressions while an MP may be interrupted in one)."""
    if len(temps) < 4:
        return temps
    isr_count = max(2, len(temps) // 4)
    split = temps.stop - isr_count
    return range(split, temps.stop) if kind == "isr" else range(temps.start, split)


@dataclass
class _Block:
    kind: str  # "for" | "if" | "while" (lowered to an IF)


class ProgramLowerer:
    """Lowers one program; label, temporary and block state are per program."""

    def __init__(self, scope: Scope, program: ast.Program, temps: range, target: str,
                 program_names: dict[str, ast.Program]) -> None:
        self.scope = scope
        self.cat = scope.catalogue
        self.profile = scope.catalogue.profile
        self.sink = scope.sink
        self.program = program
        self.kind = program.kind
        self.temps = temps
        self.own_temps = temps_for(program.kind, temps)
        self.free_temps = list(reversed(self.own_temps))
        self.target = target
        self.program_names = program_names
        self.out = LoweredProgram(program.kind, program.slot, program.name, program.source,
                                  program.span, program.end_span)
        self.blocks: list[_Block] = []
        self.labels: dict[str, int] = {}
        self.spare_labels: list[int] = []  # label numbers no LABEL of the source takes
        self.written: set[int] = set()
        self.warned_reads: set[int] = set()

    # ------------------------------------------------------------------ emitting
    def emit(self, short: str, operands: tuple[Operand, ...], span: Span) -> None:
        self.out.lines.append(MacroLine(self.cat.macro(short), operands, span))

    def emit_command(self, command: Command, operands: tuple[Operand, ...], span: Span) -> None:
        self.out.lines.append(MacroLine(command, operands, span))

    @property
    def last_command(self) -> Command | None:
        return self.out.lines[-1].command if self.out.lines else None

    # ------------------------------------------------------------------ variables
    def note_read(self, ref: VarRef, span: Span) -> None:
        """W103, except for temporaries and for declared `VAR name` variables: declaring one
        says that the host (or another program) sets it."""
        if ref.index in self.temps or ref.index in self.scope.declared_indices:
            return
        if ref.index not in self.written and ref.index not in self.warned_reads:
            self.warned_reads.add(ref.index)
            self.sink.add("W103", span, f"VAR{ref.index} is read before this program writes it",
                          hint="initialise it first, or ignore if the host or a caller sets it")

    def note_write(self, ref: VarRef) -> None:
        self.written.add(ref.index)

    def check_user_var(self, index: int, span: Span) -> bool:
        count = self.profile.var("count")
        if index >= count:
            self.sink.add("E204", span, f"VAR{index} does not exist: variables are "
                          f"VAR0..VAR{count - 1}")
            return False
        if index in self.temps:
            self.sink.add("W104", span, f"VAR{index} is in the compiler's temporary pool "
                          f"VAR{self.temps.start}..VAR{self.temps.stop - 1}",
                          hint="use another variable, or move the pool with --temp-vars")
        return True

    def user_var(self, expr: ast.Expr) -> VarRef | None:
        """The variable an expression names (VARn or alias), checked; None otherwise."""
        if isinstance(expr, ast.Group) and len(expr.items) == 1:
            return self.user_var(expr.items[0])
        if not isinstance(expr, ast.Name):
            return None
        index = self.scope.variable(expr.name)
        if index is None or not self.check_user_var(index, expr.span):
            return None
        return VarRef(index)

    def take_temp(self, span: Span) -> VarRef | None:
        if not self.free_temps:
            self.sink.add("E422", span, f"the expression needs more than the "
                          f"{len(self.own_temps)} temporary variables an "
                          f"{self.kind.upper()} may use (VAR{self.own_temps.start}.."
                          f"VAR{self.own_temps.stop - 1})",
                          hint="split it into several assignments")
            return None
        return VarRef(self.free_temps.pop())

    def give_temp(self, ref: VarRef) -> None:
        if ref.index in self.own_temps and ref.index not in self.free_temps:
            self.free_temps.append(ref.index)

    # --------------------------------------------------------------- expressions
    def fold(self, expr: ast.Expr) -> int | None:
        try:
            return self.scope.fold(expr)
        except ConstError as err:
            if err.code:
                self.sink.add(err.code, err.span, err.message)
            raise

    def check_immediate(self, value: int, span: Span) -> bool:
        low, high = self.profile.var("immediate_min"), self.profile.var("immediate_max")
        if not low <= value <= high:
            self.sink.add("E418", span, f"{value} is outside the device's immediate range "
                          f"{low:,}..{high:,}")
            return False
        return True

    def value_operand(self, expr: ast.Expr) -> Operand | None:
        """An IF/FOR/SET_VAR operand: a constant or a variable, computing expressions into a
        temporary first. The caller releases temporaries with `give_temp`."""
        try:
            value = self.fold(expr)
        except ConstError:
            return None
        if value is not None:
            return value if self.check_immediate(value, expr.span) else None
        ref = self.user_var(expr)
        if ref is not None:
            self.note_read(ref, expr.span)
            return ref
        if isinstance(expr, ast.Name) and not self.bare_query(expr.name):
            self.unknown_name(expr)
            return None
        temp = self.take_temp(expr.span)
        if temp is None:
            return None
        self.lower_into(expr, temp)
        return temp

    def unknown_name(self, expr: ast.Name) -> None:
        names = [*self.scope.const_exprs, *self.scope.aliases]
        hint = did_you_mean(expr.name, names) or "declare it with CONST or ALIAS"
        if self.profile.axis_code(expr.name) is not None:
            hint = "axis names are arguments of motion commands, not values"
        self.sink.add("E202", expr.span, f"unknown name {expr.name!r}", hint=hint)

    def lower_into(self, expr: ast.Expr, dest: VarRef) -> None:
        """Compute `expr` into variable `dest` with SET_VAR / VAR_CALCULATE lines."""
        while isinstance(expr, ast.Group) and len(expr.items) == 1:
            expr = expr.items[0]
        match expr:
            case ast.Call():
                self.lower_query(expr, dest)
            case ast.Name(name=name) if self.bare_query(name):
                self.lower_query(ast.Call(name, [], expr.span), dest)
            case ast.BinOp(op=op, left=left, right=right):
                try:
                    folded = self.fold(expr)
                except ConstError:
                    return
                if folded is not None:
                    if self.check_immediate(folded, expr.span):
                        self.emit("SET_VAR", (dest, folded), expr.span)
                    return
                if op not in self.profile.calc_ops:
                    self.sink.add("E424", expr.span, f"operator {op!r} is not computable")
                    return
                # Compute a complex left side straight into dest when the right side does
                # not read dest; otherwise through a temporary.
                left_op: Operand | None
                if self.is_complex(left) and dest.index not in self.vars_in(right):
                    self.lower_into(left, dest)
                    left_op = dest
                else:
                    left_op = self.value_operand(left)
                right_op = self.value_operand(right)
                if left_op is not None and right_op is not None:
                    self.emit("VAR_CALCULATE", (left_op, self.profile.calc_ops[op], right_op,
                                                dest), expr.span)
                for used in (left_op, right_op):
                    if isinstance(used, VarRef) and used != dest:
                        self.give_temp(used)
            case ast.Neg(operand=operand):
                inner = self.value_operand(operand)
                if inner is not None:
                    self.emit("VAR_CALCULATE", (0, self.profile.calc_ops["-"], inner, dest),
                              expr.span)
                    if isinstance(inner, VarRef):
                        self.give_temp(inner)
            case ast.Str():
                self.sink.add("E416", expr.span, "a string is not a value")
            case ast.Group():
                self.sink.add("E416", expr.span, "a list is not a value")
            case _:
                simple = self.value_operand(expr)
                if simple is not None:
                    self.emit("SET_VAR", (dest, simple), expr.span)
        self.note_write(dest)

    def bare_query(self, name: str) -> bool:
        """`VAR1 = GET_ERROR` without brackets: a read that takes no arguments."""
        if self.scope.variable(name) is not None or name.upper() in self.scope.const_exprs:
            return False
        command = self.cat.lookup(name)
        return command is not None and command.returns and not command.params

    def is_complex(self, expr: ast.Expr) -> bool:
        while isinstance(expr, ast.Group) and len(expr.items) == 1:
            expr = expr.items[0]
        if isinstance(expr, ast.Num | ast.Name):
            return False
        try:
            return self.scope.fold(expr) is None
        except ConstError:
            return False

    def vars_in(self, expr: ast.Expr) -> set[int]:
        found: set[int] = set()
        for node in _walk(expr):
            if isinstance(node, ast.Name):
                index = self.scope.variable(node.name)
                if index is not None:
                    found.add(index)
        return found

    def lower_query(self, call: ast.Call, dest: VarRef) -> None:
        command = self.cat.lookup(call.name)
        if command is None:
            self.unknown_command(call.name, call.span)
            return
        if not command.returns:
            self.sink.add("E421", call.span, f"{command.short_name} does not return a value",
                          hint="value-returning reads: " + ", ".join(
                              sorted(c.short_name for c in self.cat.commands
                                     if c.returns and c.is_macro)))
            return
        if self.command_allowed(command, call.span):
            operands = self.arguments(command, call.args, call.span)
            if operands is not None:
                self.emit_command(command, operands, call.span)
                self.emit("SET_RVAR", (dest,), call.span)
        self.note_write(dest)

    # ------------------------------------------------------------------ commands
    def unknown_command(self, name: str, span: Span) -> None:
        hint = did_you_mean(name, self.cat.all_names()) or "see docs/commands.md"
        self.sink.add("E201", span, f"unknown command {name!r}", hint=hint)

    def command_allowed(self, command: Command, span: Span) -> bool:
        """Scope checks: macro form, MP/ISR, target controller."""
        name = command.short_name
        own_close = "MP_CLOSE" if self.kind == "mp" else "MP_ISR_CLOSE"
        if name == own_close:
            self.sink.add("E406", span, f"{name} is generated by END {self.kind.upper()}",
                          hint="use EXIT to leave the program early")
            return False
        if not command.is_macro:
            if command.code is None:
                self.sink.add("E405", span, f"{command.name} reads registers from the host; "
                              "it has no macro form")
                return False
            twin = self.cat.macro_by_short.get(name)
            self.sink.add("E401", span, f"{command.name} is a real-time command and cannot be "
                          "stored in a program",
                          hint=f"use the macro form {twin.short_name} ({twin.name})" if twin
                          else "send it from the host instead")
            return False
        if self.kind not in command.scope:
            if self.kind == "isr":
                self.sink.add("E402", span, f"{name} is not allowed in an ISR",
                              hint="only commands marked for ISR in Table 1 may be used")
            else:
                self.sink.add("E403", span, f"{name} is only allowed in an ISR")
            return False
        if self.target not in command.targets:
            self.sink.add("E404", span, f"{name} does not exist on the "
                          f"{self.profile.raw['device']['variants'][self.target]}",
                          hint="build with --target " + "/".join(sorted(command.targets)))
            return False
        return True

    def arguments(self, command: Command, args: list[ast.Expr], span: Span
                  ) -> tuple[Operand, ...] | None:
        params = command.params
        if len(args) != len(params):
            signature = ", ".join(p.name for p in params) or "no arguments"
            self.sink.add("E411", args[len(params)].span if len(args) > len(params) else span,
                          f"{command.short_name} takes {len(params)} argument"
                          f"{'' if len(params) == 1 else 's'} ({signature}), "
                          f"got {len(args)}")
            return None
        operands: list[Operand] = []
        ok = True
        for param, arg in zip(params, args, strict=True):
            operand = self.argument(command, param, arg)
            if operand is None:
                ok = False
            else:
                operands.append(operand)
        return tuple(operands) if ok else None

    def argument(self, command: Command, param: Param, arg: ast.Expr) -> Operand | None:
        """Resolve and check one command argument against its catalogue description."""
        where = f"{command.short_name} {param.name}"
        while isinstance(arg, ast.Group) and len(arg.items) == 1:
            arg = arg.items[0]
        if isinstance(arg, ast.Str):
            return self.string_argument(param, arg, where)
        if isinstance(arg, ast.Call):
            self.sink.add("E421", arg.span, f"{arg.name}(...) cannot be an argument",
                          hint=f"assign it first: VARn = {arg.name}(...)")
            return None
        if isinstance(arg, ast.Name):
            named = self.named_argument(command, param, arg, where)
            if named is not False:
                return named
        try:
            value = self.fold(arg)
        except ConstError:
            return None
        if value is None:
            if isinstance(arg, ast.Name):
                self.unknown_name(arg)
            else:
                self.sink.add("E416", arg.span, f"{where} needs a constant or a variable, not "
                              "an expression", hint="compute it into a VAR first")
            return None
        return self.check_value(param, value, arg.span, where)

    def named_argument(self, command: Command, param: Param, arg: ast.Name, where: str
                       ) -> Operand | bool | None:
        """A name argument, or False if the name is not one of the special kinds."""
        upper = arg.name.upper()
        if upper in param.symbols:
            return param.symbols[upper]
        if param.kind == "cmp_op" and upper in self.profile.cmp_symbols:
            return self.profile.cmp_ops[self.profile.cmp_symbols[upper]]
        if param.kind.startswith("axis"):
            code = self.profile.axis_code(upper)
            if code is not None:
                return self.check_value(param, code, arg.span, where)
        program = PROGRAM_RE.fullmatch(upper)
        if program and param.kind in ("mp", "isr", "isr_or_none"):
            if program.group(1).lower() != param.kind.removesuffix("_or_none"):
                self.sink.add("E416", arg.span, f"{where} takes an {param.kind.upper()} number, "
                              f"not {arg.name}")
                return None
            return self.check_value(param, int(program.group(2)), arg.span, where)
        bvar = BVAR_RE.fullmatch(upper)
        if bvar and param.kind == "bvar":
            index = int(bvar.group(1))
            if index >= self.profile.var("byte_count"):
                self.sink.add("E204", arg.span, f"{arg.name} does not exist: byte variables "
                              f"are bVAR0..bVAR{self.profile.var('byte_count') - 1}")
                return None
            return BVarRef(index)
        if param.kind in ("mp", "isr", "isr_or_none") and upper in self.program_names:
            target = self.program_names[upper]
            wanted = param.kind.removesuffix("_or_none")
            if target.kind != wanted:
                self.sink.add("E416", arg.span, f"{where} takes an {wanted.upper()} number, "
                              f"but {arg.name} is an {target.kind.upper()}")
                return None
            return ProgramRef(name=upper)
        found = self.scope.variable(arg.name)
        if found is None:
            return False
        index = found
        if not self.check_user_var(index, arg.span):
            return None
        ref = VarRef(index)
        if param.kind == "var":
            self.note_write(ref)
            return ref
        if param.wire < 2 or param.kind not in ("int", "float", "bvar"):
            self.sink.add("E414", arg.span, f"{where} is a {param.type} and cannot take a "
                          "variable", hint="use a constant here")
            return None
        if not param.var:
            self.sink.add("W107", arg.span, f"the manual does not document variables for "
                          f"{where}")
        self.note_read(ref, arg.span)
        return ref

    def string_argument(self, param: Param, arg: ast.Str, where: str) -> Operand | None:
        table = {"calc_op": self.profile.calc_ops, "cmp_op": self.profile.cmp_ops}.get(param.kind)
        if table is None:
            self.sink.add("E416", arg.span, f"{where} takes a number, not a string")
            return None
        if arg.value not in table:
            self.sink.add("E424", arg.span, f"{arg.value!r} is not an operator of {where}",
                          hint="operators: " + " ".join(table))
            return None
        return table[arg.value]

    def check_value(self, param: Param, value: int, span: Span, where: str) -> Operand | None:
        kind = param.kind
        if kind == "var":
            self.sink.add("E415", span, f"{where} must be a variable (VARn), not a constant")
            return None
        if kind in ("calc_op", "cmp_op"):
            table = self.profile.calc_ops if kind == "calc_op" else self.profile.cmp_ops
            if value not in table.values():
                self.sink.add("E424", span, f"{value:#x} is not an operator code of {where}")
                return None
            return value
        if kind.startswith("axis"):
            return self.check_axis(param, value, span, where)
        low, high = param.min, param.max
        if kind == "mp":
            low, high = 1, max(self.profile.slot_numbers("mp"))
        elif kind in ("isr", "isr_or_none"):
            low = 1 if kind == "isr" else 0
            high = max(self.profile.slot_numbers("isr"))
        elif kind == "label":
            low, high = 0, self.profile.limit("label_max")
        if param.values and value not in param.values:
            names = {v: k for k, v in param.symbols.items()}
            listed = ", ".join(f"{v} ({names[v]})" if v in names else str(v)
                               for v in param.values)
            self.sink.add("E417", span, f"{where} cannot be {value}; allowed: {listed}")
            return None
        if (low is not None and value < low) or (high is not None and value > high):
            bounds = f"{low if low is not None else '-inf'}..{high if high is not None else 'inf'}"
            self.sink.add("E412", span, f"{where} = {value} is outside {bounds}")
            return None
        if param.wire == 2 and not self.check_immediate(value, span):
            return None
        if param.encoding == "holding_address":
            first = self.profile.var("holding_base")
            last = first + 2 * (self.profile.var("count") - 1)
            if first <= value <= last and (value - first) % 2 == 0:
                self.sink.add("W108", span, f"{where} = {value} is sent exactly like "
                              f"VAR{(value - first) // 2} (holding address {value})",
                              hint="put the value in a variable and pass the variable")
        if param.wire == 1 and not -0x8000 <= value <= 0xFFFF:
            self.sink.add("E412", span, f"{where} = {value} does not fit in a {param.type}")
            return None
        return value

    def check_axis(self, param: Param, value: int, span: Span, where: str) -> Operand | None:
        offset = int(self.profile.raw["axes"]["initial_table_offset"])
        if value & offset and param.kind != "axis_it":
            self.sink.add("E413", span, f"initial-table axis codes (INITIAL_*) cannot be used "
                          f"in a program ({where})", hint="configure the initial table from "
                          "the host; in a program use X, Y, Z, U")
            return None
        singles = set(self.profile.axes.values())
        allowed = {
            "axis": set(range(1, 16)),
            "axis1": singles,
            "axis1_or_none": singles | {0},
            "axis_it": set(range(1, 16)) | {c + offset for c in range(1, 16)},
        }[param.kind]
        if param.values:
            allowed &= set(param.values)
        if value not in allowed:
            if param.values:
                names = ", ".join(self.profile.axis_name(v) for v in sorted(param.values))
                self.sink.add("E413", span, f"{where} must be one of {names}, not "
                              f"{self.profile.axis_name(value) if 0 < value < 16 else value}")
                return None
            what = {"axis1": "one axis (X, Y, Z or U)",
                    "axis1_or_none": "one axis (X, Y, Z or U) or 0"}.get(param.kind,
                                                                       "an axis combination")
            self.sink.add("E413", span, f"{where} must be {what}, not "
                          f"{self.profile.axis_name(value) if 0 < value < 16 else value}")
            return None
        return value

    # ---------------------------------------------------------------- statements
    def lower_program(self) -> LoweredProgram:
        self.collect_labels(self.program.body)
        self.lower_block(self.program.body)
        return self.out

    def lower_block(self, body: list[ast.Node]) -> None:
        dead_after: Span | None = None  # set after a jump, until a LABEL makes code live
        warned = False
        for node in body:
            if isinstance(node, ast.LabelStmt):
                dead_after, warned = None, False
            elif dead_after is not None and not warned:
                self.sink.add("W101", node.span, f"unreachable: line {dead_after.line} always "
                              "jumps away", hint="remove it, or put a LABEL before it")
                warned = True
            try:
                jumps = self.lower_node(node)
            except RecursionError:  # a pathological expression: say so, never crash
                self.sink.add("E107", node.span, "the statement's expression is nested too "
                              "deeply to compile", hint="split it into several assignments")
                jumps = False
            if jumps and dead_after is None:
                dead_after = node.span

    def lower_node(self, node: ast.Node) -> bool:
        """Lower one node; True if control never falls through it."""
        match node:
            case ast.ForBlock():
                self.lower_for(node)
            case ast.IfBlock():
                self.lower_if(node)
            case ast.WhileBlock():
                self.lower_while(node)
            case ast.RepeatBlock():
                self.lower_repeat(node)
            case ast.Assign():
                self.lower_assign(node)
            case ast.Command():
                self.lower_command(node)
            case ast.LabelStmt():
                self.lower_label(node)
            case ast.Goto():
                self.lower_goto(node)
                return True
            case ast.CallStmt():
                self.lower_call(node)
            case ast.ExitFor():
                if not any(b.kind == "for" for b in self.blocks):
                    self.sink.add("E306", node.span, "EXIT FOR outside a FOR loop",
                                  hint="EXIT leaves the whole program")
                else:
                    self.emit("EXIT_FOR", (), node.span)
                return True
            case ast.Exit():
                self.emit("EXIT_MACRO", (), node.span)
                return True
            case ast.Terminate():
                self.emit("MP_TERMINATE", (), node.span)
                return True
            case ast.OnStmt():
                self.lower_on(node)
        return False

    def lower_on(self, node: ast.OnStmt) -> None:
        """`ON X P>=C+ CALL ISR 2` inside a program: INTFACTOR_ENABLE per axis (an ISR
        re-arming the next compare, as in the 7.3.12 example)."""
        from mplang.ir.configure import wire_lines, wires

        command = self.cat.macro("INTFACTOR_ENABLE")
        if not self.command_allowed(command, node.span):
            return
        self.out.lines.extend(wire_lines(wires(node, self.cat, self.sink, self.program_names),
                                         self.cat))

    def lower_for(self, node: ast.ForBlock, counter: VarRef | None = None) -> None:
        """FOR count ... NEXT; `counter`: a temporary already holding the count (REPEAT)."""
        if self.kind == "isr":
            self.sink.add("E313", node.span, "FOR loops are not allowed in an ISR")
            self.lower_block(node.body)
            return
        depth = sum(1 for b in self.blocks if b.kind == "for") + 1
        if depth > self.profile.limit("for_depth"):
            self.sink.add("E311", node.span, f"FOR nested {depth} deep; the device allows "
                          f"{self.profile.limit('for_depth')} (one outer and "
                          f"{self.profile.limit('for_depth') - 1} inner)")
        try:
            folded = self.fold(node.count)
        except ConstError:
            folded = None
        if folded is not None and folded <= 0:
            self.sink.add("W102", node.count.span, f"FOR {folded} never runs its body")
        count = self.value_operand(node.count) if counter is None else counter
        if isinstance(count, VarRef):
            self.note_write(count)  # the device counts the variable down to zero
        if count is not None:
            self.emit("FOR", (count,), node.span)
        self.blocks.append(_Block("for"))
        self.lower_block(node.body)
        self.blocks.pop()
        self.emit("NEXT", (), node.end_span)
        if isinstance(count, VarRef):
            self.give_temp(count)

    def lower_if(self, node: ast.IfBlock, body: list[ast.Node] | None = None,
                 loop_label: int | None = None) -> None:
        """IF ... [ELSE ...] END_IF; for a WHILE (`loop_label`), `body` then GOTO back."""
        depth = sum(1 for b in self.blocks if b.kind in ("if", "while")) + 1
        if depth > self.profile.limit("if_depth"):
            self.sink.add("E310", node.span, f"IF nested {depth} deep; the device allows "
                          f"{self.profile.limit('if_depth')} (one outer and "
                          f"{self.profile.limit('if_depth') - 1} inner)")
        if node.op not in self.profile.cmp_ops:
            self.sink.add("E424", node.span, f"{node.op!r} is not an IF comparison",
                          hint="comparisons: " + " ".join(self.profile.cmp_ops))
        left = self.value_operand(node.left)
        right = self.value_operand(node.right)
        if left is not None and right is not None and node.op in self.profile.cmp_ops:
            self.emit("IF", (left, self.profile.cmp_ops[node.op], right), node.span)
        for used in (left, right):
            if isinstance(used, VarRef):
                self.give_temp(used)
        if loop_label is not None:
            self.blocks.append(_Block("while"))
            self.lower_block(body or [])
            self.blocks.pop()
            self.emit("GOTO", (loop_label,), node.end_span)
            self.emit("END_IF", (), node.end_span)
            return
        self.blocks.append(_Block("if"))
        self.lower_block(node.then)
        if node.otherwise is not None:
            assert node.else_span is not None
            self.emit("ELSE", (), node.else_span)
            self.lower_block(node.otherwise)
        self.blocks.pop()
        self.emit("END_IF", (), node.end_span)

    def lower_while(self, node: ast.WhileBlock) -> None:
        """LABEL top / IF cond / body / GOTO top / END_IF: the condition is computed after
        the label, so every round tests it afresh; one label, no counter."""
        problem = None
        if self.kind == "isr":
            problem = "an ISR has no labels, and a WHILE loop needs one"
        elif self.blocks:
            inner = self.blocks[-1].kind.upper()
            problem = (f"WHILE inside {'an' if inner == 'IF' else 'a'} {inner} block: its "
                       "LABEL would stand inside a block, which the device refuses")
        elif not self.spare_labels:
            self.sink.add("E329", node.span, f"WHILE needs one of the program's "
                          f"{self.profile.limit('labels_per_program')} labels, and they are "
                          "all taken", hint="free a LABEL, or move the loop into a program "
                          "of its own and CALL it")
            self.lower_block(node.body)
            return
        if problem is not None:
            self.sink.add("E328", node.span, problem, hint="move the loop to the top level of "
                          "an MP (a called MP of its own works inside any block), or use FOR "
                          "with EXIT FOR")
            self.lower_block(node.body)
            return
        label = self.spare_labels.pop(0)
        self.emit("LABEL", (label,), node.span)
        self.lower_if(ast.IfBlock(node.left, node.op, node.right, [], None, node.span, None,
                                  node.end_span), body=node.body, loop_label=label)

    def lower_repeat(self, node: ast.RepeatBlock) -> None:
        """A FOR; a count that is a variable of the user's is copied first, because the
        device counts FOR's variable down to zero."""
        copy: VarRef | None = None
        if isinstance(node.count, ast.Name) and self.kind == "mp" and \
                self.scope.variable(node.count.name) is not None:
            copy = self.take_temp(node.span)
            if copy is not None:
                self.lower_into(node.count, copy)
        self.lower_for(ast.ForBlock(node.count, node.body, node.span, node.end_span),
                       counter=copy)

    def lower_assign(self, node: ast.Assign) -> None:
        index = self.scope.variable(node.target)
        if index is None:
            self.sink.add("E423", node.target_span, f"cannot assign to {node.target!r}: not a "
                          "variable", hint="assign to VARn or to an ALIAS of one")
            return
        if not self.check_user_var(index, node.target_span):
            return
        self.lower_into(node.value, VarRef(index))

    def lower_command(self, node: ast.Command) -> None:
        command = self.cat.lookup(node.name)
        if command is None:
            self.unknown_command(node.name, node.name_span)
            return
        if not self.command_allowed(command, node.name_span):
            return
        operands = self.arguments(command, node.args, node.span)
        if operands is None:
            return
        if command.short_name == "SET_RVAR" and not (self.last_command and
                                                      self.last_command.returns):
            self.sink.add("W106", node.span, "SET_RVAR without a value-returning read right "
                          "before it", hint="write VARn = GET_LP(X) instead")
        self.emit_command(command, operands, node.span)

    def collect_labels(self, body: list[ast.Node]) -> None:
        """Number the program's labels: numeric ones keep their number, names take the lowest
        free numbers in order of definition."""
        defined: dict[str, Span] = {}
        for node in _statements(body):
            if not isinstance(node, ast.LabelStmt):
                continue
            key = node.label.upper()
            if key in defined:
                self.sink.add("E322", node.span, f"label {node.label} is defined twice",
                              related=((defined[key], "first definition"),))
                continue
            defined[key] = node.span
            if key.isdigit():
                number = int(key)
                if number > self.profile.limit("label_max"):
                    self.sink.add("E326", node.span, f"label {number} does not exist: labels "
                                  f"are 0..{self.profile.limit('label_max')}")
                    continue
                self.labels[key] = number
        free = [n for n in range(self.profile.limit("labels_per_program"))
                if n not in self.labels.values()]
        self.spare_labels = free  # what named labels leave is for WHILE loops
        for key, span in defined.items():
            if key.isdigit():
                continue
            if not free:
                self.sink.add("E321", span, f"more than {self.profile.limit('labels_per_program')}"
                              " labels in one program", hint="split the program, or reuse "
                              "labels")
                continue
            self.labels[key] = free.pop(0)

    def lower_label(self, node: ast.LabelStmt) -> None:
        if self.kind == "isr":
            self.sink.add("E327", node.span, "LABEL cannot be used in an ISR")
            return
        for block in self.blocks:
            code = "E324" if block.kind == "for" else "E323"
            self.sink.add(code, node.span, f"LABEL inside {block.kind.upper()} block"
                          + (" (its body is inside an IF)" if block.kind == "while" else ""),
                          hint="labels must stand outside FOR and IF blocks; jumping out of "
                          "a block is fine")
            return
        if node.label.upper() in self.labels:
            self.emit("LABEL", (self.labels[node.label.upper()],), node.span)

    def lower_goto(self, node: ast.Goto) -> None:
        if self.kind == "isr":
            self.sink.add("E327", node.span, "GOTO cannot be used in an ISR")
            return
        key = node.label.upper()
        if key not in self.labels:
            if key.isdigit() and int(key) > self.profile.limit("label_max"):
                self.sink.add("E326", node.span, f"label {key} does not exist: labels are "
                              f"0..{self.profile.limit('label_max')}")
            else:
                self.sink.add("E325", node.span, f"GOTO {node.label}: no LABEL {node.label} in "
                              "this program", hint="jumps stay inside one program")
            return
        self.emit("GOTO", (self.labels[key],), node.span)

    def lower_call(self, node: ast.CallStmt) -> None:
        command = self.cat.macro("MP_CALL")
        if not self.command_allowed(command, node.span):
            return
        upper = node.target.upper()
        program = PROGRAM_RE.fullmatch(upper)
        ref: ProgramRef
        if program and program.group(1) == "ISR":
            self.sink.add("E431", node.span, f"CALL {node.target}: ISRs are started by "
                          "interrupts, not called")
            return
        if program or upper.isdigit():
            slot = int(program.group(2) if program else upper)
            if slot not in self.profile.slot_numbers("mp"):
                self.sink.add("E501", node.span, f"MP{slot} does not exist: slots are "
                              f"MP1..MP{max(self.profile.slot_numbers('mp'))}")
                return
            ref = ProgramRef(slot=slot)
        elif upper in self.program_names:
            target = self.program_names[upper]
            if target.kind != "mp":
                self.sink.add("E431", node.span, f"CALL {node.target}: it is an ISR")
                return
            ref = ProgramRef(name=upper)
        else:
            hint = did_you_mean(node.target, list(self.program_names)) or \
                "CALL a program of this build by name, or any slot as MPn"
            self.sink.add("E434", node.span, f"no program named {node.target!r} in this build",
                          hint=hint)
            return
        self.out.calls.append(CallSite(ref, node.span))
        self.emit_command(command, (ref,), node.span)


def _walk(expr: ast.Expr) -> Iterator[ast.Expr]:
    yield expr
    match expr:
        case ast.BinOp(left=left, right=right):
            yield from _walk(left)
            yield from _walk(right)
        case ast.Neg(operand=operand):
            yield from _walk(operand)
        case ast.Group(items=items) | ast.Call(args=items):
            for item in items:
                yield from _walk(item)


def _statements(body: list[ast.Node]) -> Iterator[ast.Node]:
    for node in body:
        yield node
        if isinstance(node, ast.ForBlock):
            yield from _statements(node.body)
        elif isinstance(node, ast.IfBlock):
            yield from _statements(node.then)
            yield from _statements(node.otherwise or [])
        elif isinstance(node, ast.WhileBlock | ast.RepeatBlock):
            yield from _statements(node.body)
