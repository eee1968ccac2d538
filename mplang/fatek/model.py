"""The FBs-PLC positioning program as data: tables of steps, FUN141 parameter tables and the
simulation set-up of a listing.

Both front ends produce this model: the parser of native `.fbs` listings and the `.mp`
compiler. The checker, the writers (listing, register table, JSON) and the virtual controller
only ever see this model. Spans are kept beside the content and never take part in equality,
so a table written out and read back compares equal to the original.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.lang.diagnostics import Span


@dataclass(frozen=True, order=True)
class Register:
    """A 16-bit PLC data register, `R1000` or `D100`; a 32-bit operand names its low word."""

    kind: str  # "R" | "D"
    number: int

    def __str__(self) -> str:
        return f"{self.kind}{self.number}"

    def offset(self, words: int) -> Register:
        return Register(self.kind, self.number + words)


Value = int | Register
"""An operand: a constant or the register that holds the value at run time."""


@dataclass(frozen=True, order=True)
class Contact:
    """A bit a WAIT or EXT waits for: X (input), Y (output), M (relay), S (step relay)."""

    kind: str
    number: int

    def __str__(self) -> str:
        return f"{self.kind}{self.number}"


@dataclass(frozen=True)
class Drive:
    """DRV / DRVC: one single-axis stroke (FB 890-983)."""

    op: str  # "DRV" | "DRVC"
    coord: str  # "ADR" relative | "ABS" absolute
    direction: str  # "+", "-" or "" (the sign of the stroke decides)
    stroke: Value
    unit: str  # "Ut" | "Ps"

    def text(self) -> str:
        return f"{self.op} {self.coord},{self.direction},{_value(self.stroke)},{self.unit}"


@dataclass(frozen=True)
class Home:
    """DRVZ MD0-MD2: machine home return (FB 1042-1061, 3256-3456)."""

    mode: int

    def text(self) -> str:
        return f"DRVZ MD{self.mode}"


@dataclass(frozen=True)
class Line:
    """LIN / LINE: a straight line over Ps0-Ps3 (FB 2211-2299); None is a blank axis."""

    op: str  # "LIN" | "LINE"
    coord: str
    strokes: tuple[Value | None, Value | None, Value | None, Value | None]
    unit: str

    def text(self) -> str:
        axes = ",".join("" if s is None else _value(s) for s in self.strokes)
        return f"{self.op} {self.coord},{axes},{self.unit}"


Motion = Drive | Home | Line


@dataclass(frozen=True)
class Condition:
    """The transition condition of a step (FB 1081-1133)."""

    op: str  # "WAIT" | "ACT" | "EXT"
    time: Value | None = None  # WAIT TIME / ACT TIME, in 0.01 s
    contact: Contact | None = None

    def text(self) -> str:
        if self.time is not None:
            return f"{self.op} TIME,{_value(self.time)}"
        return f"{self.op} {self.contact}"


NEXT = "NEXT"
Target = str | int | Register
"""A GOTO target: "NEXT", a step number, or the register that holds the step number."""


@dataclass
class Step:
    """One positioning point: output speed, motion and transition (FB 571-575)."""

    number: int
    speed: Value | None = None
    motion: Motion | None = None
    condition: Condition | None = None
    goto: Target | None = None
    mend: bool = False
    span: Span = field(default=Span("<none>", 0), compare=False)
    spans: dict[str, Span] = field(default_factory=dict, compare=False)
    note: str = field(default="", compare=False)  # where a compiled step came from

    def lines(self) -> list[str]:
        """The step as the listing prints it, one instruction per line."""
        out = []
        if self.speed is not None:
            out.append(f"SPD {_value(self.speed)}")
        if self.motion is not None:
            out.append(self.motion.text())
        if self.condition is not None:
            out.append(self.condition.text())
        if self.goto is not None:
            out.append(f"GOTO {_value(self.goto) if not isinstance(self.goto, str) else NEXT}")
        if self.mend:
            out.append("MEND")
        return out

    def where(self, part: str) -> Span:
        """The span of a part of the step (falls back to the step's first line)."""
        return self.spans.get(part) or self.span


@dataclass
class PositioningTable:
    """A FUN140 (one axis, Ps0-Ps3) or FUN147 (interpolation group, Gp0-Gp1) program table."""

    name: str
    fun: int  # 140 | 147
    unit: int  # Ps for FUN140, Gp for FUN147
    sr: Register | None = None
    wr: Register | None = None
    steps: list[Step] = field(default_factory=list)
    declared: bool = True  # written with a TABLE line (an implicit table has none)
    span: Span = field(default=Span("<none>", 0), compare=False)
    source: str = field(default="", compare=False)
    origin: str = field(default="", compare=False)  # `MP21` for a table compiled from MP21

    @property
    def unit_name(self) -> str:
        return f"{'Ps' if self.fun == 140 else 'Gp'}{self.unit}"


@dataclass
class ParamTable:
    """A FUN141 MPARA table of one axis: the parameters written in the source (the others keep
    their defaults)."""

    name: str
    axis: int
    sr: Register | None = None
    values: dict[int, int] = field(default_factory=dict)
    span: Span = field(default=Span("<none>", 0), compare=False)
    spans: dict[int, Span] = field(default_factory=dict, compare=False)
    source: str = field(default="", compare=False)

    fun = 141


Table = PositioningTable | ParamTable


@dataclass(frozen=True)
class ContactEvent:
    """`SIM X0 ON AT 1.5`: the contact turns ON (or OFF) at a time of the run."""

    contact: Contact
    time: float
    state: bool
    span: Span = field(default=Span("<none>", 0), compare=False)


@dataclass(frozen=True)
class WindowSensor:
    """`SIM X3 ON WHILE Ps0 IN -9000..-8000`: ON while the axis's position is in the window,
    a DOG, limit or deceleration-point sensor."""

    contact: Contact
    axis: int
    low: int
    high: int
    span: Span = field(default=Span("<none>", 0), compare=False)


@dataclass(frozen=True)
class PulseSensor:
    """`SIM X4 PULSE Ps0 EVERY 2000`: a zero-phase (PG0) pulse each time the axis's position
    crosses a multiple of `every` pulses."""

    contact: Contact
    axis: int
    every: int
    span: Span = field(default=Span("<none>", 0), compare=False)


@dataclass
class SimSetup:
    """What the virtual controller needs besides the program: register contents and the
    machine's contacts. Written as `SIM` lines in a listing; it is not part of the PLC table."""

    registers: dict[Register, int] = field(default_factory=dict)  # 16-bit words
    events: list[ContactEvent] = field(default_factory=list)
    windows: list[WindowSensor] = field(default_factory=list)
    pulses: list[PulseSensor] = field(default_factory=list)
    spans: dict[Register, Span] = field(default_factory=dict, compare=False)

    def merge(self, other: SimSetup) -> None:
        self.registers.update(other.registers)
        self.spans.update(other.spans)
        self.events.extend(other.events)
        self.windows.extend(other.windows)
        self.pulses.extend(other.pulses)

    def is_empty(self) -> bool:
        return not (self.registers or self.events or self.windows or self.pulses)


def _value(value: Value | int) -> str:
    return str(value)


def word(value: int) -> int:
    """A value as an unsigned 16-bit register word."""
    return value & 0xFFFF


def split32(value: int) -> tuple[int, int]:
    """A 32-bit value as two registers, low word first (FB 877-878)."""
    value &= 0xFFFFFFFF
    return value & 0xFFFF, value >> 16


def join32(low: int, high: int) -> int:
    """Two registers (low word first) as a signed 32-bit value."""
    value = (low & 0xFFFF) | (high & 0xFFFF) << 16
    return value - (1 << 32) if value & 0x80000000 else value
