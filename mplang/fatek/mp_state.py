"""What the compile-time evaluation of `.mp` macro lines (mplang/fatek/compile.py) works on.

The values a macro line can hold at compile time, the frames and FOR/IF/LABEL map of the
programs being evaluated, the step drafts, the build-wide `Context`, and `EvaluatorBase`: the
state of one MP's evaluation with the operand and diagnostic helpers that the groups of macro
lines (mplang/fatek/mp_flow.py, mplang/fatek/mp_moves.py) share.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.fatek.model import Motion, Register, Target, Value
from mplang.fatek.profile import Profile
from mplang.ir.catalogue import Catalogue
from mplang.ir.macro import BVarRef, LoweredProgram, MacroLine, Operand, ProgramRef, VarRef
from mplang.lang.diagnostics import DiagnosticSink, Span


@dataclass(frozen=True)
class HostVar:
    """The value the host left in VARn: passed to the PLC as a register."""

    index: int


@dataclass(frozen=True)
class Runtime:
    """A value the program computes while it runs; the PLC has nowhere to compute it."""

    span: Span
    what: str


Val = int | HostVar | Runtime


@dataclass
class Loop:
    start: int  # index of the FOR line
    ref: VarRef | None
    counter: int


@dataclass
class Frame:
    program: LoweredProgram
    flow: Flow
    pc: int = 0
    loops: list[Loop] = field(default_factory=list)


@dataclass
class Flow:
    """Where FOR/NEXT, IF/ELSE/END IF, EXIT FOR and LABEL lines lead (like the device's)."""

    for_end: dict[int, int] = field(default_factory=dict)
    if_false: dict[int, int] = field(default_factory=dict)
    else_end: dict[int, int] = field(default_factory=dict)
    exit_for_end: dict[int, int] = field(default_factory=dict)
    labels: dict[int, int] = field(default_factory=dict)

    @classmethod
    def of(cls, lines: list[MacroLine]) -> Flow:
        flow = cls()
        stack: list[tuple[str, int]] = []
        pending_exits: dict[int, list[int]] = {}
        open_else: dict[int, int] = {}
        for index, line in enumerate(lines):
            name = line.command.short_name
            if name == "FOR":
                stack.append(("for", index))
            elif name == "NEXT" and stack and stack[-1][0] == "for":
                start = stack.pop()[1]
                flow.for_end[start] = index
                for exit_line in pending_exits.pop(start, []):
                    flow.exit_for_end[exit_line] = index
            elif name == "IF":
                stack.append(("if", index))
            elif name == "ELSE" and stack and stack[-1][0] == "if":
                start = stack[-1][1]
                flow.if_false[start] = index
                open_else[start] = index
            elif name == "END_IF" and stack and stack[-1][0] == "if":
                start = stack.pop()[1]
                if start in open_else:
                    flow.else_end[open_else.pop(start)] = index
                else:
                    flow.if_false[start] = index
            elif name == "EXIT_FOR":
                loop = next((i for kind, i in reversed(stack) if kind == "for"), None)
                if loop is not None:
                    pending_exits.setdefault(loop, []).append(index)
            elif name == "LABEL" and isinstance(line.operands[0], int):
                flow.labels[line.operands[0]] = index
        return flow


@dataclass
class Draft:
    """A step being built: the move, its speed and the wait that follows it."""

    speed: Value
    motion: Motion
    span: Span
    speed_span: Span
    wait_ms: int = 0
    wait_span: Span | None = None
    goto: Target | None = None
    goto_span: Span | None = None


@dataclass
class AxisState:
    speed: Val | None = None
    speed_span: Span | None = None
    position: int | None = None  # known absolute position (pulses), None: unknown
    waited: bool = True  # STOP_WAIT since the last move (for the timing warning)


@dataclass
class LabelVisit:
    steps: int
    last_wait: int | None


class Context:
    """What every program evaluation of one build shares."""

    def __init__(self, programs: list[LoweredProgram], catalogue: Catalogue, profile: Profile,
                 sink: DiagnosticSink, fun: int) -> None:
        self.programs = programs
        self.catalogue = catalogue
        self.m8194h = catalogue.profile
        self.profile = profile
        self.sink = sink
        self.fun = fun
        self.flows = {id(p): Flow.of(p.lines) for p in programs}
        self.by_name = {p.name.upper(): p for p in programs if p.name}
        self.by_slot = {p.slot: p for p in programs if p.kind == "mp" and p.slot is not None}
        self.calc = {code: symbol for symbol, code in self.m8194h.calc_ops.items()}
        self.compare = {code: symbol for symbol, code in self.m8194h.cmp_ops.items()}
        raw = profile.raw["compile"]
        self.var_kind = str(raw["var_register"])
        self.var_stride = int(raw["var_register_stride"])
        self.default_axes = tuple(int(a) for a in raw["default_assigned_axes"])

    def resolve(self, ref: ProgramRef) -> LoweredProgram | None:
        if ref.name is not None:
            return self.by_name.get(ref.name.upper())
        return self.by_slot.get(ref.slot) if ref.slot is not None else None

    def host_register(self, var: HostVar) -> Register:
        return Register(self.var_kind, self.var_stride * var.index)


class EvaluatorBase:
    """The state of one MP's evaluation, and what every group of macro lines uses."""

    def __init__(self, context: Context, program: LoweredProgram, name: str) -> None:
        self.cx = context
        self.sink = context.sink
        self.top = program
        self.name = name
        self.fun = context.fun
        self.limits = context.profile.limits(context.fun)
        self.vars: dict[int, Val] = {}
        self.rvalue: Val = Runtime(program.span, "a read's result")
        self.axes = [AxisState() for _ in range(4)]
        self.vector_speed: Val | None = None
        self.vector_span: Span | None = None
        self.assigned: tuple[int, ...] = context.default_axes
        self.table_axis: int | None = None
        self.drafts: list[Draft] = []
        self.visits: dict[tuple[object, ...], LabelVisit] = {}
        self.params: dict[int, dict[int, tuple[int, Span]]] = {}
        self.stack: list[Frame] = []
        self.stopped = False
        self.lost_move = False  # a move was reported and left out: waits after it are moot

    # ------------------------------------------------------------ values
    def val(self, operand: Operand) -> Val:
        if isinstance(operand, VarRef):
            return self.vars.get(operand.index, HostVar(operand.index))
        if isinstance(operand, BVarRef | ProgramRef):
            return Runtime(self.top.span, "a byte variable")
        return int(operand)

    def operand(self, value: Val, span: Span, what: str) -> Value | None:
        """A PLC operand for `value`: a constant, or the register a host variable lives in."""
        if isinstance(value, int):
            return value
        if isinstance(value, HostVar):
            return self.cx.host_register(value)
        self.sink.add("E642", span, f"{what} is computed at run time ({value.what}, line "
                      f"{value.span.line}); the PLC reads operands from constants or registers",
                      hint="compute it at compile time, or let the host write VARn and pass "
                      "VARn itself")
        return None

    def fail(self, code: str, span: Span, message: str, hint: str = "") -> None:
        self.sink.add(code, span, message, hint=hint)
        if code in ("E642", "E643", "E647", "E648"):
            self.lost_move = True

    def frame(self, program: LoweredProgram) -> Frame:
        return Frame(program, self.cx.flows[id(program)])


def round10(value: int) -> int:
    """Milliseconds as WAIT TIME's 0.01 s, rounded half up."""
    return (value + 5) // 10
