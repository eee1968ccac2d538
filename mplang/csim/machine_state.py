"""The virtual CSIM's state (mplang/csim/machine.py runs it): variables, parameters, I/O,
logical axes, the stored program's run state, events and simulated time, over the motion
model of mplang/csim/motion.py.

`MachineState` holds what every group of commands reads and changes (values, linked modules,
logical axes, inputs, events); the commands themselves are in mplang/csim/machine_motion.py,
machine_flow.py and machine_data.py, which `Machine` joins.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from mplang.csim.motion import INF, MotionModel
from mplang.csim.profile import Profile
from mplang.csim.syntax import Operand, Script, Statement

LOGICAL = ("X", "Y", "Z", "W")
AXIS_REPORT_NAMES = ("X", "Y", "Z", "U")
MOVE_AXIS = {"XMA": 0, "YMA": 1, "ZMA": 2, "WMA": 3, "XMR": 0, "YMR": 1, "ZMR": 2, "WMR": 3}
WAIT_AXIS = {"XDN": 0, "YDN": 1, "ZDN": 2, "WDN": 3}
CLOSE = 1e-9


class RunError(Exception):
    """The program (or a host command) cannot go on: the device's error state."""


class NotModelled(RunError):
    """A command or query the virtual CSIM does not simulate (W702 warns about them)."""


def float32(value: float) -> float:
    """The value as a 32-bit float holds it (R variables, see real_format in the profile)."""
    try:
        stored = float(struct.unpack("f", struct.pack("f", value))[0])
    except OverflowError:
        stored = math.inf
    if math.isinf(stored) or math.isnan(stored):  # struct rounds some overflows to inf
        raise RunError(f"{value:g} does not fit a 32-bit real")
    return stored


def format_number(value: float) -> str:
    """Whole numbers without a decimal point, others with up to 6 decimals."""
    rounded = round(value, 6)
    if rounded == int(rounded):
        return str(int(rounded))
    return f"{rounded:.6f}".rstrip("0").rstrip(".")


@dataclass
class Wait:
    """A line that holds the program: `done()` says whether it may go on; `wake()` is the
    next simulated time worth checking again (INF: only an outside change can help)."""

    line: str
    done: Callable[[], bool]
    wake: Callable[[], float]
    on_timeout: Callable[[], None] | None = None


@dataclass
class Event:
    variable: int | None = None  # NZ,Nk: fires when Nk != 0
    handler: int | None = None
    last: bool = False
    depth: int | None = None  # call depth of its running handler


@dataclass
class Sample:
    time: float
    positions: dict[str, float]


@dataclass
class MachineState:
    """The virtual CSIM's whole state."""

    profile: Profile
    script: Script = field(default_factory=lambda: Script("program", "<device>"))
    sample_period: float | None = None

    def __post_init__(self) -> None:
        modules = self.profile.modules
        self.motion = MotionModel(modules)
        self.clock = 0.0
        self.line_time = float(self.profile.fact("program", "line_time_s"))
        self.defaults = {k: float(v) for k, v in self.profile.section("defaults").items()
                         if not k.endswith("_choice")}
        self.module_params: list[dict[str, float]] = [dict(self.defaults)
                                                      for _ in range(modules)]
        self.params: dict[str, float] = {"FU": 1, "TOSYN": 0, "CM": 0}
        pn37 = int(self.profile.fact("logical_axes", "virtual_pn37"))
        self.params["PN37"] = pn37
        self.params["PN50"] = int(self.profile.fact("logical_axes", "virtual_pn50"))
        self.logical = [(pn37 >> (4 * i)) & 0xF for i in range(4)]
        self.held = [bool(self.profile.fact("motion", "power_on_hold"))] * modules
        self.offsets = [0.0] * modules  # coordinate - machine position (CS, H)
        self.n = [0] * self.profile.n_count
        self.r = [0.0] * self.profile.r_count
        self.ns = [0] * self.profile.array_size
        self.rs = [0.0] * self.profile.array_size
        self.inputs = [False] * self.profile.inputs
        self.outputs = [False] * self.profile.outputs
        self.pulse_until = [0.0] * self.profile.outputs
        self.events = [Event() for _ in range(self.profile.events)]
        self.host_lines: deque[str] = deque()
        self.printed: list[str] = []
        self.touched: set[int] = set()
        self.tm_base = 0.0
        self.reset_run()
        self.samples: list[Sample] = []
        self._last_sample = -INF
        self._was_moving = False

    # ------------------------------------------------------------------- run state
    def reset_run(self) -> None:
        self.running = False
        self.pc = 0
        self.stack: list[int] = []
        self.wait: Wait | None = None
        self.error: str | None = None
        self.error_code = "R401"  # what kind of run-time finding `error` is
        self.error_address: int | None = None  # the line it stopped at, if one
        self.finished = False
        self.steps = 0
        self.wait_address = 0  # the line that set `wait` (an event returns to it)

    def start(self, address: int = 0) -> None:
        """G addr: run the stored program from an address."""
        if self.script.statements and not 0 <= address < len(self.script.statements):
            raise RunError(f"address {address} is past the end of the program")
        self.reset_run()
        self.pc = address
        self.running = bool(self.script.statements)
        self.finished = not self.running
        for event in self.events:
            event.last = False
            event.depth = None

    def stop(self, error: str | None = None, code: str = "R401",
             address: int | None = None) -> None:
        """End the program; `error` (a run-time finding `code`, mplang.lang.runtime_rules)
        at line `address` if it failed."""
        self.running = False
        self.wait = None
        self.error = error
        self.error_code, self.error_address = code, address
        self.finished = error is None

    def resolve(self, operand: Operand) -> int:
        if operand.kind == "label":
            labels = self.script.labels
            name = operand.text[1:].upper()
            if name not in labels:
                raise RunError(f"label {operand.text} is not defined")
            return labels[name]
        address = int(operand.value)
        if not 0 <= address < len(self.script.statements):
            raise RunError(f"address {address} is past the end of the program")
        return address

    # ------------------------------------------------------------------ time passing
    def advance_to(self, t: float) -> None:
        """Let simulated time run to t, sampling positions on the way if asked to."""
        if t <= self.clock:
            return
        if self.sample_period is None:
            self.motion.advance(t)
            self.clock = t
            return
        period = self.sample_period
        if self.motion.moving() and not self._was_moving:
            self.sample()  # where a motion starts from
        while True:
            moving = self.motion.moving()
            next_grid = (math.floor(self.clock / period + CLOSE) + 1) * period if moving else INF
            corners = [c for m in self.motion.active for c in m.segment_end_times()
                       if self.clock + CLOSE < c <= t]
            corners += [c for c in self.motion.stop_times() if self.clock + CLOSE < c <= t]
            stop_at = min(t, next_grid, self.motion.next_event(), *corners)
            self.motion.advance(stop_at)
            self.clock = stop_at
            if moving or self.motion.finished_times:
                self.sample()
                self.motion.finished_times.clear()
            if stop_at >= t:
                self._was_moving = self.motion.moving()
                return

    def sample(self) -> None:
        if self.samples and self.clock <= self._last_sample:
            self.samples.pop()
        self._last_sample = self.clock
        self.samples.append(Sample(self.clock, self.axis_positions()))

    def axis_positions(self) -> dict[str, float]:
        """Positions for a sample, rounded to 1e-9 unit (arcs leave float dust behind)."""
        return {self.axis_name(m): round(self.motion.position(m), 9) + 0.0
                for m in self.reported_modules()}

    def axis_name(self, module: int) -> str:
        return AXIS_REPORT_NAMES[module] if module < len(AXIS_REPORT_NAMES) else f"T{module}"

    def reported_modules(self) -> list[int]:
        return [m for m in range(self.profile.modules) if m < 4 or m in self.touched]

    # --------------------------------------------------------------------- values
    def value(self, operand: Operand) -> float:
        match operand.kind:
            case "number":
                return operand.value
            case "nvar":
                return self.n[operand.index]
            case "rvar":
                return self.r[operand.index]
            case "nsvar":
                return self.ns[operand.index]
            case "rsvar":
                return self.rs[operand.index]
        raise RunError(f"{operand.text} is not a value")

    def store(self, target: Operand, value: float) -> None:
        if target.is_integer_variable:
            whole = math.trunc(value)
            if not self.profile.n_min <= whole <= self.profile.n_max:
                raise RunError(f"{whole} does not fit {target.canonical} "
                               f"({self.profile.n_min}..{self.profile.n_max})")
            if target.kind == "nvar":
                self.n[target.index] = whole
            else:
                self.ns[target.index] = whole
        elif target.kind == "rvar":
            self.r[target.index] = float32(value)
        else:
            self.rs[target.index] = float32(value)

    def linked_modules(self) -> list[int]:
        mask = int(self.params["PN50"]) | 1
        return [m for m in range(self.profile.modules) if mask >> m & 1]

    def require_linked(self, module: int) -> None:
        if module not in self.linked_modules():
            raise RunError(f"module T{module} is not linked (PN50 bit {module} is 0)")

    # -------------------------------------------------------------- modules and axes
    def prefixed_module(self, st: Statement) -> int:
        module = 0 if st.prefix is None else st.prefix
        self.require_linked(module)
        return module

    def logical_module(self, axis: int) -> int:
        module = self.logical[axis]
        if module > int(self.profile.fact("logical_axes", "module_max")):
            raise RunError(f"logical axis {LOGICAL[axis]} has no module (T{LOGICAL[axis]}=8): "
                           f"set T{LOGICAL[axis]}=p first")
        self.require_linked(module)
        return module

    # ---------------------------------------------------------------- inputs, events
    def input_on(self, operand: Operand) -> bool:
        return self.inputs[int(self.value(operand)) - 1]

    def check_events(self) -> None:
        """Fire an event whose condition has just become true (edge), as a CALL."""
        if not self.running:
            return
        for event in self.events:
            if event.variable is None or event.handler is None:
                continue
            now = self.n[event.variable] != 0
            rising = now and not event.last
            event.last = now
            if rising and event.depth is None:
                resume = self.pc
                if self.wait is not None:
                    resume = self.wait_address
                    self.wait = None
                self.stack.append(resume)
                event.depth = len(self.stack)
                self.pc = event.handler
