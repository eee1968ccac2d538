"""Checking CSIM lines against the manual's command list (stdlib/csim/commands.toml).

Per line: the command or parameter exists, takes the module prefix if one is written, may be
used where it stands (stored in a program, or sent from the host), has the right number and
kinds of operands inside their ranges, and names existing variables. Per program: every jump
target exists, labels are unique, and code nothing reaches is reported. The same checks
answer a host's line on the virtual CSIM, so what `mpc lint` accepts the device accepts.
"""

from __future__ import annotations

import difflib

from mplang.csim.profile import CommandSpec, OperandSpec, ParameterSpec, Profile
from mplang.csim.syntax import Operand, Script, Statement
from mplang.lang.diagnostics import DiagnosticSink, Span

KIND_TEXT = {
    "real": "a number", "int": "an integer", "rvar": "a real variable Rn",
    "nvar": "an integer variable Nn or NS(i)", "var": "a variable",
    "value": "a number or a variable", "addr": "a label $NAME or an address",
    "port": "an output P1..P4", "input": "an input number", "event": "an event EVn",
    "word": "a keyword", "text": 'a "string"', "switch": "a DIP switch number",
}
UNCONDITIONAL = {"JP", "RET"}
JUMPS_WITH_TARGET_LAST = {"JP", "JI", "JNI", "JZ", "JNZ", "JE", "JNE", "JG", "JNG", "JTI",
                          "JNTI", "CALL", "ON EV", "G"}
P2P_MOTION = {"MA", "MR", "JGF", "JGR", "JG0", "H", "FT"}


def _did_you_mean(name: str, candidates: list[str]) -> str:
    close = difflib.get_close_matches(name, candidates, n=1, cutoff=0.6)
    return f"did you mean {close[0]}?" if close else ""


class Checker:
    """Checks lines for one context: "program" (a stored line) or "immediate" (from the host)."""

    def __init__(self, profile: Profile, sink: DiagnosticSink, context: str = "program") -> None:
        self.profile = profile
        self.sink = sink
        self.context = context

    # ------------------------------------------------------------------- one statement
    def statement(self, statement: Statement) -> None:
        if statement.kind == "command":
            self.command(statement)
        elif statement.kind == "assign":
            self.assignment(statement)
        elif statement.kind == "query":
            self.query(statement)

    def command(self, st: Statement) -> None:
        spec = self.profile.commands.get(st.name)
        if spec is None:
            self.unknown(st)
            return
        if not self.prefix_ok(st, spec.prefix):
            return
        if self.context not in spec.use:
            self.misplaced(st, spec.use)
            return
        self.operands(st, spec)
        if not spec.modelled and self.context == "program":
            self.sink.add("W702", st.name_span, f"{spec.name} is not modelled by the virtual "
                          f"CSIM ({spec.summary.rstrip('.').lower()})",
                          hint="mpc run stops with an error when it reaches this line; "
                          "test it on the device")

    def unknown(self, st: Statement) -> None:
        if st.name in self.profile.parameters:
            self.sink.add("E702", st.name_span, f"{st.name} is a parameter, not a command",
                          hint=f"set it with {st.name}=value")
            return
        candidates = [*self.profile.commands, *self.profile.parameters]
        hint = _did_you_mean(st.name, candidates) or "see the command list in docs/csim.md"
        self.sink.add("E702", st.name_span, f"unknown command {st.name}", hint=hint)

    def prefix_ok(self, st: Statement, allowed: bool) -> bool:
        if st.prefix is None:
            return True
        last = self.profile.modules - 1
        if not allowed:
            self.sink.add("E707", st.name_span, f"{st.name} takes no module prefix T{st.prefix}",
                          hint="only single-module commands and parameters take Tp; "
                          "coordinated commands use the logical axes (TX..TW)")
            return False
        if st.prefix > last:
            self.sink.add("E707", st.name_span, f"module T{st.prefix} does not exist: "
                          f"modules are T0..T{last}")
            return False
        return True

    def misplaced(self, st: Statement, use: frozenset[str]) -> None:
        if self.context == "program":
            self.sink.add("E711", st.name_span, f"{st.name} cannot be stored in a program: it is "
                          "a command for the host", hint="send it from the host (mpc sim, a "
                          "terminal), not as a program line")
        else:
            self.sink.add("E711", st.name_span, f"{st.name} can only run inside a program",
                          hint="store it in a program (PG/DLP) and run it with G")

    def operands(self, st: Statement, spec: CommandSpec) -> None:
        required = sum(1 for o in spec.operands if not o.optional)
        given = len(st.operands)
        if not required <= given <= len(spec.operands):
            want = (str(required) if required == len(spec.operands)
                    else f"{required} to {len(spec.operands)}")
            names = ", ".join(o.name for o in spec.operands) or "no operands"
            self.sink.add("E703", st.name_span, f"{spec.name} takes {want} operand"
                          f"{'' if want == '1' else 's'} ({names}), not {given}",
                          hint=f"{spec.name}: {spec.summary}")
            return
        ok = True
        for operand, want_spec in zip(st.operands, spec.operands, strict=False):
            ok = self.operand(operand, want_spec, spec.name) and ok
        if not ok:
            return
        if any(o.is_variable for o in st.operands) and self.context not in spec.var_use:
            self.sink.add("E711", st.name_span, f"{spec.name} with variable operands can only "
                          "run inside a program (CS 175)",
                          hint="give the values as numbers, or store the line in a program")
        if spec.name in ("JE", "JNE", "JG", "JNG"):
            self.same_type(st.operands[0], st.operands[1], spec.name)

    def operand(self, operand: Operand, spec: OperandSpec, command: str) -> bool:
        """Kind and range of one operand; False (reported) if it does not fit."""
        kinds = spec.kinds
        matched = next((k for k in kinds if self.kind_matches(operand, k)), None)
        if matched is None:
            expected = " or ".join(KIND_TEXT.get(k, k) for k in kinds)
            hint = ""
            if operand.kind == "word" and operand.text.upper().endswith(")"):
                hint = "functions are not documented for CSIM"
            elif operand.kind == "number" and "int" in kinds:
                hint = "this operand takes a whole number"
            self.sink.add("E704", operand.span, f"{command} operand {spec.name} must be "
                          f"{expected}, not {operand.text!r}", hint=hint)
            return False
        if operand.is_variable:
            return self.variable(operand)
        if matched in ("real", "int", "value") and operand.kind == "number":
            return self.in_range(operand, spec.min, spec.max, False, f"{command} {spec.name}")
        if matched == "port":
            return self.numbered(operand, 1, self.profile.outputs, "output", "P")
        if matched == "input":
            return self.numbered(operand, 1, self.profile.inputs, "input", "")
        if matched == "switch":
            switches = int(self.profile.fact("device", "dip_switches"))
            return self.numbered(operand, 1, switches, "DIP switch", "")
        if matched == "event":
            return self.numbered(operand, 1, self.profile.events, "event", "EV")
        if matched == "addr" and operand.kind == "number":
            return self.in_range(operand, 0, None, False, f"{command} address")
        return True

    def kind_matches(self, operand: Operand, kind: str) -> bool:
        match kind:
            case "real":
                return operand.kind == "number"
            case "int" | "input" | "switch":
                return operand.integral
            case "rvar":
                return operand.kind in ("rvar", "rsvar")
            case "nvar":
                return operand.kind in ("nvar", "nsvar")
            case "var":
                return operand.is_variable
            case "value":
                return operand.kind == "number" or operand.is_variable
            case "addr":
                return operand.kind == "label" or operand.integral
            case "port":
                return operand.kind == "port"
            case "event":
                return operand.kind == "event"
            case "word":
                return operand.kind == "word"
            case "text":
                return operand.kind == "string"
        return False

    def variable(self, operand: Operand) -> bool:
        if operand.kind in ("nvar", "rvar"):
            count = self.profile.n_count if operand.kind == "nvar" else self.profile.r_count
            letter = operand.kind[0].upper()
            if operand.index >= count:
                self.sink.add("E706", operand.span, f"{operand.canonical} does not exist: "
                              f"variables are {letter}0..{letter}{count - 1}")
                return False
            return True
        size = self.profile.array_size
        if operand.index >= size:
            name = "NS" if operand.kind == "nsvar" else "RS"
            self.sink.add("E706", operand.span, f"{operand.canonical} does not exist: the array "
                          f"is {name}(0)..{name}({size - 1})")
            return False
        return True

    def numbered(self, operand: Operand, low: int, high: int, what: str, letter: str) -> bool:
        if not low <= operand.index <= high or (operand.kind == "number"
                                                and not operand.integral):
            self.sink.add("E705", operand.span, f"{what} {operand.text} does not exist: "
                          f"{what}s are {letter}{low}..{letter}{high}")
            return False
        return True

    def in_range(self, operand: Operand, low: float | None, high: float | None,
                 exclusive_low: bool, what: str) -> bool:
        value = operand.value
        too_low = low is not None and (value <= low if exclusive_low else value < low)
        too_high = high is not None and value > high
        if too_low or too_high:
            lower = "" if low is None else (f"> {low:g}" if exclusive_low else f">= {low:g}")
            upper = "" if high is None else f"<= {high:g}"
            bounds = " and ".join(b for b in (lower, upper) if b)
            self.sink.add("E705", operand.span, f"{what} must be {bounds}, not {operand.text}")
            return False
        return True

    def same_type(self, c: Operand, var: Operand, command: str) -> None:
        """JE/JNE/JG/JNG: c must be of #var's type (CS 85-88)."""
        if c.is_variable and c.is_integer_variable != var.is_integer_variable:
            self.sink.add("E704", c.span, f"{command} compares {c.canonical} with "
                          f"{var.canonical}: c must have the type of #var (CS 85)",
                          hint="compare integers with integers and reals with reals")
        elif c.kind == "number" and var.is_integer_variable and not c.integral:
            self.sink.add("E704", c.span, f"{command}: {c.text} is not an integer, but "
                          f"{var.canonical} is an integer variable (CS 85)")
        elif c.kind == "number" and var.is_integer_variable:
            self.n_value(c)

    def n_value(self, operand: Operand) -> bool:
        low, high = self.profile.n_min, self.profile.n_max
        if not low <= operand.value <= high:
            self.sink.add("E705", operand.span, f"{operand.text} does not fit an integer "
                          f"variable ({low}..{high}, CS 136)")
            return False
        return True

    # ------------------------------------------------------------------ assignments
    def assignment(self, st: Statement) -> None:
        if st.target is None:
            self.parameter(st)
            return
        if not self.variable(st.target):
            return
        values_ok = all(self.variable(o) if o.is_variable else self.value_operand(o, st)
                        for o in st.operands)
        if not values_ok:
            return
        if st.operator is not None or any(o.is_variable for o in st.operands):
            form = "arithmetic" if st.operator else "assignment from a variable"
            self.sink.add("W701", st.span, f"{form} is not in the CSIM command list: "
                          f"'{st.text}' is mplang's reading", hint="check the spelling on the "
                          "device (see docs/csim.md, arithmetic)")
        if st.operator == "/" and st.operands[1].kind == "number" and st.operands[1].value == 0:
            self.sink.add("E705", st.operands[1].span, "division by zero")
        if st.target.is_integer_variable and st.operator is None:
            value = st.operands[0]
            if value.kind == "number":
                if not value.integral:
                    self.sink.add("E704", value.span, f"{st.target.canonical} is an integer "
                                  f"variable: {value.text} is not an integer")
                else:
                    self.n_value(value)

    def value_operand(self, operand: Operand, st: Statement) -> bool:
        if operand.kind == "number":
            return True
        hint = ("functions are not documented for CSIM" if operand.kind == "word" else "")
        self.sink.add("E704", operand.span, f"{operand.text!r} is not a value (a number or a "
                      "variable)", hint=hint)
        return False

    def parameter(self, st: Statement) -> None:
        spec = self.profile.parameters.get(st.name)
        if spec is None:
            self.unknown_parameter(st)
            return
        if not self.prefix_ok(st, spec.prefix):
            return
        if self.context not in spec.use:
            self.misplaced(st, spec.use)
            return
        if st.operator is not None or len(st.operands) != 1:
            self.sink.add("E704", st.operands[0].span, f"{spec.name} takes one value, not an "
                          "expression", hint="compute the value into a variable first")
            return
        self.parameter_value(st.operands[0], spec)
        if not spec.modelled and self.context == "program":
            self.sink.add("W702", st.name_span, f"{spec.name} is not modelled by the virtual "
                          f"CSIM ({spec.summary.rstrip('.').lower()})",
                          hint="mpc run stops with an error when it reaches this line")

    def unknown_parameter(self, st: Statement) -> None:
        name = st.name
        if (name.startswith(("PN", "PR")) and name[2:].isdigit()) and st.operator is None:
            if st.prefix is not None and st.prefix >= self.profile.modules:
                self.prefix_ok(st, True)
                return
            self.sink.add("W703", st.name_span, f"parameter {name} is not described in the "
                          "CSIM command list", hint="the virtual CSIM stores it without effect; "
                          "check its meaning in the drive's parameter manual")
            return
        hint = _did_you_mean(name, list(self.profile.parameters))
        if name in self.profile.commands:
            hint = f"{name} is a command: write '{name} value' without '='"
        self.sink.add("E712", st.name_span, f"unknown parameter {name}",
                      hint=hint or "parameters: " + ", ".join(self.profile.parameters))

    def parameter_value(self, operand: Operand, spec: ParameterSpec) -> None:
        kinds = spec.kinds
        if operand.is_variable:
            wanted = {"nvar": ("nvar", "nsvar"), "rvar": ("rvar", "rsvar")}
            if not any(operand.kind in wanted.get(k, ()) for k in kinds):
                self.sink.add("E704", operand.span, f"{spec.name} takes a number, not the "
                              f"variable {operand.canonical}")
                return
            self.variable(operand)
            return
        if operand.kind != "number" or not any(k in ("int", "real") for k in kinds):
            self.sink.add("E704", operand.span, f"{spec.name} takes "
                          f"{' or '.join(KIND_TEXT.get(k, k) for k in kinds)}, not "
                          f"{operand.text!r}")
            return
        if "real" not in kinds and not operand.integral:
            self.sink.add("E704", operand.span, f"{spec.name} takes an integer, not "
                          f"{operand.text}")
            return
        if spec.values and int(operand.value) not in spec.values:
            allowed = ", ".join(str(v) for v in spec.values)
            self.sink.add("E705", operand.span, f"{spec.name} takes one of {allowed}, not "
                          f"{operand.text} ({spec.lines})")
            return
        self.in_range(operand, spec.min, spec.max, spec.exclusive_min, spec.name)

    # ---------------------------------------------------------------------- queries
    def query(self, st: Statement) -> None:
        if self.context == "program":
            self.sink.add("E711", st.name_span, f"?{st.name} is a query for the host and cannot "
                          "be stored in a program", hint="use OUT #var to print from a program")
            return
        if st.name in ("NS", "RS") or (len(st.operands) == 0 and _is_var_name(st.name)):
            if st.prefix is not None:
                self.sink.add("E707", st.name_span, "variables take no module prefix")
            elif st.operands:
                self.variable(st.operands[0])
            else:
                kind = "nvar" if st.name[0] == "N" else "rvar"
                self.variable(Operand(kind, st.name, st.name_span, int(st.name[1:])))
            return
        spec = self.profile.queries.get(st.name)
        if spec is None:
            hint = _did_you_mean(st.name, list(self.profile.queries))
            self.sink.add("E702", st.name_span, f"unknown query ?{st.name}", hint=hint)
            return
        if not self.prefix_ok(st, spec.prefix):
            return
        want = 1 if spec.operand else 0
        if len(st.operands) != want:
            self.sink.add("E703", st.name_span, f"?{spec.name} takes {want} operand"
                          f"{'' if want == 1 else 's'}, not {len(st.operands)}")
            return
        if spec.operand:
            self.operand(st.operands[0], OperandSpec("n", (spec.operand,)), f"?{spec.name}")

    # --------------------------------------------------------------------- programs
    def script(self, script: Script) -> None:
        """Every line, then labels, jump targets and reachability."""
        for st in script.statements:
            self.statement(st)
        self.labels(script)
        self.unreachable(script)

    def labels(self, script: Script) -> None:
        first: dict[str, Statement] = {}
        for st in script.statements:
            if st.kind != "label":
                continue
            if st.name in first:
                self.sink.add("E709", st.name_span, f"label ${st.name} is defined twice",
                              related=((first[st.name].span, "first definition"),))
            else:
                first[st.name] = st
        length = len(script.statements)
        for st in script.statements:
            for target in jump_targets(st):
                if target.kind == "label" and target.text[1:].upper() not in first:
                    hint = _did_you_mean(target.text[1:].upper(), list(first))
                    self.sink.add("E708", target.span, f"label {target.text} is not defined in "
                                  "this program", hint=hint or "define it on a line of its "
                                  f"own: {target.text}")
                elif target.kind == "number" and target.integral and target.value >= length:
                    self.sink.add("E710", target.span, f"address {target.text} is past the end "
                                  f"of the program (addresses 0..{length - 1})",
                                  hint="addresses count the program's lines from 0; prefer "
                                  "a label")

    def unreachable(self, script: Script) -> None:
        targeted = {int(t.value) for st in script.statements for t in jump_targets(st)
                    if t.kind == "number" and t.integral}
        dead = False
        for address, st in enumerate(script.statements):
            if st.kind == "label" or address in targeted:
                dead = False
            elif dead:
                self.sink.add("W704", st.span, f"'{st.text}' is never reached: the line before "
                              "jumps or returns unconditionally", hint="remove it, or put a "
                              "label before it")
                dead = False  # once per run of dead lines
                continue
            if st.kind == "command" and st.name in UNCONDITIONAL:
                dead = True


def jump_targets(st: Statement) -> list[Operand]:
    """The address operands of a line (the last operand of jumps, calls and ON EV)."""
    if st.kind != "command" or st.name not in JUMPS_WITH_TARGET_LAST or not st.operands:
        return []
    last = st.operands[-1]
    return [last] if last.kind in ("label", "number") else []


def _is_var_name(name: str) -> bool:
    return len(name) > 1 and name[0] in "NR" and name[1:].isdigit()


def check_script(script: Script, profile: Profile, sink: DiagnosticSink) -> None:
    Checker(profile, sink, "program").script(script)


def first_error(sink: DiagnosticSink) -> tuple[str, Span, str] | None:
    errors = sink.sorted()
    for diagnostic in errors:
        if diagnostic.severity.value == "error":
            return diagnostic.code, diagnostic.span, diagnostic.message
    return None
