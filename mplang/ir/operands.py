"""Expressions and command arguments to operands: the lower half of `ProgramLowerer`.

`OperandLowerer` emits macro lines, tracks variables and the program's temporaries, computes
expressions through temporaries into SET_VAR / VAR_CALCULATE lines, and checks command
arguments against the catalogue's parameter descriptions. `lower.ProgramLowerer` adds the
statements and blocks; `configure.InitLowerer` reuses the argument checks for INIT.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.ir.catalogue import Command, Param
from mplang.ir.fold import walk_expr
from mplang.ir.macro import BVarRef, LoweredProgram, MacroLine, Operand, ProgramRef, VarRef
from mplang.ir.scope import BVAR_RE, PROGRAM_RE, ConstError, Scope, did_you_mean, temps_for
from mplang.lang import ast
from mplang.lang.diagnostics import Span

if TYPE_CHECKING:
    from mplang.ir.blockmemo import VariableLog


_UNKNOWN = object()


class OperandLowerer:
    """Per-program state, emitting, variables and temporaries, expressions and command
    arguments: everything of a program's lowering below its statements (`ProgramLowerer`)."""

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
        self.written: set[int] = set()
        self.warned_reads: set[int] = set()
        # the profile's numbers every statement checks against, read once per program
        profile = self.profile
        self.var_count = profile.var("count")
        self.immediate_min = profile.var("immediate_min")
        self.immediate_max = profile.var("immediate_max")
        self.initial_table_offset = int(profile.raw["axes"]["initial_table_offset"])
        self.log: VariableLog | None = None  # set while a kept statement is recorded
        # constant arguments resolved: (id of the parameter, a number?, value) -> operand
        self._resolved: dict[tuple[int, bool, object], Operand | None] = {}

    # ------------------------------------------------------------------ emitting
    def emit(self, short: str, operands: tuple[Operand, ...], span: Span) -> None:
        self.out.lines.append(MacroLine(self.cat.macro(short), operands, span))

    def emit_command(self, command: Command, operands: tuple[Operand, ...], span: Span) -> None:
        self.out.lines.append(MacroLine(command, operands, span))

    @property
    def last_command(self) -> Command | None:
        return self.out.lines[-1].command if self.out.lines else None

    # ------------------------------------------------------------------ variables
    def note_read(self, ref: VarRef, span: Span, expr: ast.Expr | None = None) -> None:
        """W103, except for temporaries and for declared `VAR name` variables: declaring one
        says that the host (or another program) sets it. The message names the variable as
        the source wrote it (an ALIAS `hits`, with its number beside: `hits (VAR30)`)."""
        if ref.index in self.temps or ref.index in self.scope.declared_indices:
            return
        if self.log is not None:
            self.log.reads.add(ref.index)
        if ref.index not in self.written and ref.index not in self.warned_reads:
            self.warned_reads.add(ref.index)
            if self.log is not None:
                self.log.warned.add(ref.index)
            self.sink.add("W103", span, f"{self.var_words(ref, expr)} is read before this "
                          "program writes it",
                          hint="initialise it first, or ignore if the host or a caller sets it")

    @staticmethod
    def var_words(ref: VarRef, expr: ast.Expr | None) -> str:
        """`hits (VAR30)` for a name, `VAR30` for the device's own name."""
        while isinstance(expr, ast.Group) and len(expr.items) == 1:
            expr = expr.items[0]
        device = f"VAR{ref.index}"
        if isinstance(expr, ast.Name) and expr.name.upper() != device:
            return f"{expr.name} ({device})"
        return device

    def note_write(self, ref: VarRef) -> None:
        if self.log is not None and ref.index not in self.written:
            self.log.writes.add(ref.index)
        self.written.add(ref.index)

    def check_user_var(self, index: int, span: Span) -> bool:
        count = self.var_count
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
        low, high = self.immediate_min, self.immediate_max
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
            self.note_read(ref, expr.span, expr)
            return ref
        if isinstance(expr, ast.Name) and not self.bare_query(expr.name):
            self.unknown_name(expr)
            return None
        temp = self.take_temp(expr.span)
        if temp is None:
            return None
        self.lower_into(expr, temp)
        return temp

    def unknown_name(self, expr: ast.Name,
                     accepted: tuple[list[str], str] | None = None) -> None:
        """E202; for an argument that takes names of its own (`accepted`: the names and
        the sentence listing them), the message lists them and the hint picks among them."""
        if accepted is not None:
            names, listing = accepted
            axis = " takes an axis: " in listing
            hint = did_you_mean(expr.name, names) or (
                "write an axis name (the controller's axes are X, Y, Z and U), or an ALIAS "
                "or CONST of one" if axis else
                "write one of the names listed, or a CONST that holds one of the values"
                if names else "write one of these numbers, or a CONST that holds one")
            self.sink.add("E202", expr.span, f"unknown name {expr.name!r}; {listing}",
                          hint=hint)
            return
        names = [*self.scope.const_exprs, *self.scope.aliases]
        hint = did_you_mean(expr.name, names) or \
            f"declare it: `VAR {expr.name}` for a variable the program and the host share, " \
            "CONST for a fixed value, ALIAS for another name of a VARn"
        if self.profile.axis_code(expr.name) is not None:
            hint = "axis names are arguments of motion commands, not values"
        self.sink.add("E202", expr.span, f"unknown name {expr.name!r}", hint=hint)

    def accepted(self, param: Param, where: str) -> tuple[list[str], str] | None:
        """The names and values an enumerated argument takes (from the catalogue), or None
        for an argument that takes numbers in general."""
        if param.kind == "cmp_op":
            names = sorted(self.profile.cmp_symbols)
            return names, f"{where} takes one of {', '.join(names)}"
        if param.kind.startswith("axis") and not param.symbols:
            codes = sorted(c for c in self.profile.allowed_axes(param.kind, param.values)
                           if 0 < c < 16)
            names = [self.profile.axis_name(c) for c in codes]
            single = [n for n in names if len(n) == 1]
            shown = ", ".join(names) if len(names) <= 4 else \
                f"{', '.join(single)} or a combination of them (XY, XYZU, ...)"
            return names, f"{where} takes an axis: {shown}"
        if param.kind != "enum" and not param.symbols:
            return None
        by_value = {v: k for k, v in param.symbols.items()}
        values = param.values or sorted(by_value)
        listed = ", ".join(f"{by_value[v]} ({v})" if v in by_value else str(v) for v in values)
        return list(param.symbols), f"{where} takes one of {listed}"

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
        for node in walk_expr(expr):
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
        """Resolve and check one command argument against its catalogue description. A
        number or a name that resolved to a constant with nothing to report resolves so for
        the same parameter everywhere in the program (the names' meanings are the build's):
        it is resolved once (`_resolved`), as programs repeat their settings."""
        if isinstance(arg, ast.Num):
            key: tuple[int, bool, object] | None = (id(param), True, arg.value)
        elif isinstance(arg, ast.Name):
            key = (id(param), False, arg.name)
        else:
            key = None
        if key is not None:
            known = self._resolved.get(key, _UNKNOWN)
            if known is not _UNKNOWN:
                return known  # type: ignore[return-value]
            reported = len(self.sink.items)
            operand = self.resolve_argument(command, param, arg)
            if len(self.sink.items) == reported and not isinstance(operand, VarRef):
                self._resolved[key] = operand  # no W103 state read, nothing said
            return operand
        return self.resolve_argument(command, param, arg)

    def resolve_argument(self, command: Command, param: Param, arg: ast.Expr
                         ) -> Operand | None:
        """`argument`, worked out."""
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
                self.unknown_name(arg, self.accepted(param, where))
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
        self.note_read(ref, arg.span, arg)
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
            last = first + 2 * (self.var_count - 1)
            if first <= value <= last and (value - first) % 2 == 0:
                self.sink.add("W108", span, f"{where} = {value} is sent exactly like "
                              f"VAR{(value - first) // 2} (holding address {value})",
                              hint="put the value in a variable and pass the variable")
        if param.wire == 1 and not -0x8000 <= value <= 0xFFFF:
            self.sink.add("E412", span, f"{where} = {value} does not fit in a {param.type}")
            return None
        return value

    def check_axis(self, param: Param, value: int, span: Span, where: str) -> Operand | None:
        offset = self.initial_table_offset
        if value & offset and param.kind != "axis_it":
            self.sink.add("E413", span, f"initial-table axis codes (INITIAL_*) cannot be used "
                          f"in a program ({where})", hint="configure the initial table from "
                          "the host; in a program use X, Y, Z, U")
            return None
        if value not in self.profile.allowed_axes(param.kind, param.values):
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

