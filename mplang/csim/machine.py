"""The virtual CSIM: variables, parameters, I/O, logical axes, the stored program and its
interpreter, over the motion model of mplang/csim/motion.py.

One `Machine` serves both `mpc run` (driven in simulated time as fast as it computes) and
the virtual device on a serial line (driven by the wall clock, see mplang/csim/device.py).
Program lines take `line_time_s` each; waits (DN, WT, WI, ...) let simulated time run to the
next moment something can change. Every reading of what the manual leaves open is in
stdlib/csim/device.toml and docs/csim.md.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from mplang.csim.motion import (
    INF,
    Arc,
    Jog,
    Line,
    MotionError,
    MotionModel,
    Request,
    Segment,
    angle_between,
)
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
        return float(struct.unpack("f", struct.pack("f", value))[0])
    except OverflowError:
        raise RunError(f"{value:g} does not fit a 32-bit real") from None


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
class Machine:
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
        self._handlers = self.handlers()

    # ------------------------------------------------------------------- run state
    def reset_run(self) -> None:
        self.running = False
        self.pc = 0
        self.stack: list[int] = []
        self.wait: Wait | None = None
        self.error: str | None = None
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

    def stop(self, error: str | None = None) -> None:
        self.running = False
        self.wait = None
        self.error = error
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

    # ---------------------------------------------------------------------- running
    def run(self, max_time: float, max_steps: int = 5_000_000) -> None:
        """Run the started program until it ends, fails, or simulated time passes
        max_time; then let the motions in progress finish (within max_time)."""
        if self.sample_period is not None:
            self.sample()
        self.run_until(max_time, max_steps, offline=True)
        if self.running:
            self.stop(f"still running after {max_time:g} s of simulated time")
            return
        self.settle(max_time)

    def run_until(self, until: float, max_steps: int | None = None,
                  offline: bool = False) -> None:
        """Execute lines and waits until simulated time reaches `until` or the program
        stops. Offline (mpc run) a wait that nothing can end is an error; on the device the
        host may still change an input, so time just runs on."""
        while self.running and self.clock < until:
            if max_steps is not None and self.steps >= max_steps:
                self.stop(f"more than {max_steps} lines executed: an endless loop?")
                return
            if self.wait is not None:
                if self.wait.done():
                    self.wait = None
                    continue
                wake = min(self.wait.wake(), self.motion.next_event(), self.pulse_wake())
                if wake == INF and offline:
                    self.stop(f"'{self.wait.line}' waits for ever: nothing in the run can "
                              "change what it waits for")
                    return
                self.advance_to(min(max(wake, self.clock), until))
                continue
            self.step()
        if not self.running and not offline:
            self.advance_to(until)  # the motions go on without a program

    def settle(self, max_time: float) -> None:
        """After the program: let the buffered motions run out (not jogs)."""
        while self.motion.busy() and not self.error:
            due = self.motion.next_event()
            if due == INF:
                return
            if due > max_time:
                self.error = f"motion still running after {max_time:g} s of simulated time"
                self.finished = False
                return
            self.advance_to(due)
        if self.sample_period is not None:
            self.sample()

    def pulse_wake(self) -> float:
        pending = [t for t in self.pulse_until if t > self.clock]
        return min(pending, default=INF)

    def step(self) -> None:
        """Execute the line at pc (one line time)."""
        statements = self.script.statements
        if self.pc >= len(statements):
            self.stop()
            return
        statement = statements[self.pc]
        address = self.pc
        self.pc += 1
        self.steps += 1
        try:
            self.execute(statement, in_program=True)
        except (RunError, MotionError) as exc:
            self.stop(f"line {address} '{statement.text}': {exc}")
            return
        if self.wait is not None:
            self.wait_address = address
        self.check_events()
        self.advance_to(self.clock + self.line_time)

    # ------------------------------------------------------------------- dispatching
    def execute(self, st: Statement, in_program: bool) -> list[str]:
        """Run one statement; returns the lines it prints to the host (queries)."""
        if st.kind == "label":
            return []
        if st.kind == "assign":
            self.assign(st)
            return []
        if st.kind == "query":
            return [self.query(st)]
        name = st.name
        spec = self.profile.commands.get(name)
        if spec is not None and not spec.modelled:
            raise NotModelled(f"{name} is not modelled by the virtual CSIM")
        handler = self._handlers.get(name)
        if handler is None:
            raise RunError(f"{name} cannot run here")
        handler(st)
        return []

    def handlers(self) -> dict[str, Callable[[Statement], None]]:
        table: dict[str, Callable[[Statement], None]] = {
            "MA": self.single_move, "MR": self.single_move,
            "2MA": self.line_move, "2MR": self.line_move, "3MA": self.line_move,
            "3MR": self.line_move, "4MA": self.line_move, "4MR": self.line_move,
            "AA": self.arc_move, "AR": self.arc_move, "SAA": self.arc_move,
            "SAR": self.arc_move, "JGF": self.jog, "JGR": self.jog, "JG0": self.jog_stop,
            "H": self.home, "CS": self.coordinate_set, "HON": self.hold, "HOFF": self.hold,
            "IHON": self.hold, "IHOFF": self.hold, "RESET": self.reset_module,
            "SET": self.output, "CLR": self.output, "CHG": self.output, "ISET": self.output,
            "ICLR": self.output, "PLS": self.pulse, "OUTP": self.output_all,
            "JP": self.jump, "JI": self.jump_input, "JNI": self.jump_input,
            "JZ": self.jump_zero, "JNZ": self.jump_zero, "JE": self.jump_compare,
            "JNE": self.jump_compare, "JG": self.jump_compare, "JNG": self.jump_compare,
            "JTI": self.jump_timed, "JNTI": self.jump_timed, "CALL": self.call,
            "RET": self.ret, "WI": self.wait_input, "WNI": self.wait_input,
            "WT": self.wait_time, "DN": self.wait_done, "SET EV": self.set_event,
            "ON EV": self.on_event, "PZ": self.buffer_control, "REDO": self.buffer_control,
            "CLR BUF": self.buffer_control, "TAPZ": self.path_control,
            "TAREDO": self.path_control, "TAUPZ": self.path_control,
            "TASTOP": self.path_control, "CM": self.continuous_mode, "OUT": self.out,
            "DATA": self.data, "GETI": self.get_number, "GETR": self.get_number,
        }
        for name in MOVE_AXIS:
            table[name] = self.logical_move
        for name in WAIT_AXIS:
            table[name] = self.wait_logical
        return table

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

    def assign(self, st: Statement) -> None:
        if st.target is None:
            self.set_parameter(st)
            return
        values = [self.value(o) for o in st.operands]
        result = values[0]
        if st.operator is not None:
            result = self.arithmetic(st.operator, values[0], values[1],
                                     all(_integral_operand(o) for o in st.operands))
        self.store(st.target, result)
        self.check_events()

    def arithmetic(self, op: str, a: float, b: float, integers: bool) -> float:
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if b == 0:
            raise RunError("division by zero")
        if integers:
            quotient = abs(int(a)) // abs(int(b))
            return quotient if (a >= 0) == (b >= 0) else -quotient
        return a / b

    # ------------------------------------------------------------------ parameters
    def set_parameter(self, st: Statement) -> None:
        name = st.name
        value = self.value(st.operands[0])
        module = 0 if st.prefix is None else st.prefix
        if name in ("TX", "TY", "TZ", "TW"):
            axis = "XYZW".index(name[1])
            self.logical[axis] = int(value)
            if int(value) != int(self.profile.fact("logical_axes", "unassigned")):
                self.touched.add(int(value))
            return
        if name == "TVM":
            for m in self.linked_modules():
                self.module_params[m]["PR3"] = value
            self.motion.set_coordinated_speed(value)
            return
        if name in ("PR2", "PR3", "PR7", "VM", "VJ") or name.startswith(("PN", "PR")):
            if name == "PN50":
                self.params[name] = int(value) | 1
                return
            if name == "PN37":
                self.params[name] = int(value)
                return
            self.require_linked(module)
            self.module_params[module][name] = value
            return
        if name == "TM":
            self.tm_base = self.clock - value
            return
        if name == "AIN":
            raise NotModelled("AIN is not modelled by the virtual CSIM")
        self.params[name] = value

    def linked_modules(self) -> list[int]:
        mask = int(self.params["PN50"]) | 1
        return [m for m in range(self.profile.modules) if mask >> m & 1]

    def require_linked(self, module: int) -> None:
        if module not in self.linked_modules():
            raise RunError(f"module T{module} is not linked (PN50 bit {module} is 0)")

    # ---------------------------------------------------------------------- motion
    def prefixed_module(self, st: Statement) -> int:
        module = 0 if st.prefix is None else st.prefix
        self.require_linked(module)
        return module

    def p2p_module(self, st: Statement) -> int:
        """The module of a point-to-point command; CS 176 forbids P2P on a module that is a
        logical axis, except the host T0."""
        module = self.prefixed_module(st)
        if module != 0 and module in self.logical:
            axis = LOGICAL[self.logical.index(module)]
            raise RunError(f"T{module} is logical axis {axis}: point-to-point commands may "
                           f"not drive it (CS 176); use {axis}MA/{axis}MR")
        return module

    def check_motion_allowed(self, modules: tuple[int, ...]) -> None:
        if self.motion.path_paused:
            raise RunError("paused by TAPZ: only TAREDO or TAUPZ are accepted")
        for module in modules:
            if not self.held[module]:
                raise RunError(f"T{module} is not held (HOFF): HON first")
            self.touched.add(module)

    def single_request(self, module: int, target: Callable[[float], float], label: str
                       ) -> Request:
        params = self.module_params[module]
        speed, accel = params["VM"], params["PR2"]
        if speed <= 0 or accel <= 0:
            raise RunError(f"T{module}: VM and PR2 must be positive")

        def lay(start: tuple[float, ...]) -> Segment:
            return Line(start, (target(start[0]),))

        return Request((module,), False, speed, accel, lay=lay, label=label)

    def single_move(self, st: Statement) -> None:
        module = self.p2p_module(st)
        self.move_module(module, st.name.endswith("A"), self.value(st.operands[0]), st.text)

    def move_module(self, module: int, absolute: bool, value: float, label: str) -> None:
        self.check_motion_allowed((module,))
        if absolute:
            request = self.single_request(module, lambda _start: value, label)
        else:
            request = self.single_request(module, lambda start: start + value, label)
        self.motion.issue(request)

    def logical_module(self, axis: int) -> int:
        module = self.logical[axis]
        if module > int(self.profile.fact("logical_axes", "module_max")):
            raise RunError(f"logical axis {LOGICAL[axis]} has no module (T{LOGICAL[axis]}=8): "
                           f"set T{LOGICAL[axis]}=p first")
        self.require_linked(module)
        return module

    def logical_move(self, st: Statement) -> None:
        module = self.logical_module(MOVE_AXIS[st.name])
        self.move_module(module, st.name.endswith("A"), self.value(st.operands[0]), st.text)

    def coordinated_modules(self, count: int) -> tuple[int, ...]:
        modules = tuple(self.logical_module(axis) for axis in range(count))
        if len(set(modules)) != len(modules):
            raise RunError("two logical axes share one module")
        limit = int(self.profile.fact("device", "interpolating_modules"))
        for module in modules:
            if module >= limit:
                raise RunError(f"T{module} cannot interpolate: only T0..T{limit - 1} can "
                               "(CS 176)")
        return modules

    def coordinated_request(self, modules: tuple[int, ...], lay: Callable[[tuple[float, ...]],
                            Segment], label: str) -> Request:
        self.check_motion_allowed(modules)
        speeds = {self.module_params[m]["PR3"] for m in modules}
        accels = {self.module_params[m]["PR2"] for m in modules}
        if len(speeds) > 1 or len(accels) > 1:
            raise RunError("PR2 and PR3 must be the same on every axis of a coordinated move "
                           "(CS 180): " + ", ".join(
                               f"T{m} PR2={format_number(self.module_params[m]['PR2'])} "
                               f"PR3={format_number(self.module_params[m]['PR3'])}"
                               for m in modules))
        speed, accel = speeds.pop(), accels.pop()
        if speed <= 0 or accel <= 0:
            raise RunError("PR2 and PR3 must be positive")
        return Request(modules, True, speed, accel, lay=lay, label=label)

    def line_move(self, st: Statement) -> None:
        count = int(st.name[0])
        modules = self.coordinated_modules(count)
        values = [self.value(o) for o in st.operands]
        absolute = st.name.endswith("A")

        def lay(start: tuple[float, ...]) -> Segment:
            target = tuple(values) if absolute else tuple(
                s + v for s, v in zip(start, values, strict=True))
            return Line(start, target)

        self.issue_coordinated(self.coordinated_request(modules, lay, st.text))

    def arc_move(self, st: Statement) -> None:
        helix = st.name.startswith("S")
        modules = self.coordinated_modules(3 if helix else 2)
        fx, fy, fa = (self.value(o) for o in st.operands[:3])
        fz = self.value(st.operands[3]) if helix else None
        absolute = st.name.endswith("AA")

        def lay(start: tuple[float, ...]) -> Segment:
            centre = (fx, fy) if absolute else (start[0] + fx, start[1] + fy)
            z_target = None
            if fz is not None:
                z_target = fz if absolute else start[2] + fz
            return Arc(start, centre, math.radians(fa), z_target)

        self.issue_coordinated(self.coordinated_request(modules, lay, st.text))

    def issue_coordinated(self, request: Request) -> None:
        mode = int(self.params["CM"])
        threshold = self.module_params[request.modules[0]]["PR7"]
        shapes = set(self.profile.fact("motion", "cm2_shapes"))

        def within_angle(previous: Request, new: Request) -> bool:
            a, b = previous.segments[-1], new.segments[0]
            two_d = {"line2", "arc2"}
            if not ({a.shape, b.shape} <= two_d or a.shape == b.shape == "line3"):
                return False
            if not {a.shape, b.shape} <= shapes:
                return False
            return angle_between(a.direction(True), b.direction(False)) <= threshold + CLOSE

        blend = {1: _always, 2: within_angle}.get(mode)
        self.motion.issue(request, blend)

    def jog(self, st: Statement) -> None:
        module = self.p2p_module(st)
        self.check_motion_allowed((module,))
        params = self.module_params[module]
        sign = 1 if st.name == "JGF" else -1

        def lay(start: tuple[float, ...]) -> Segment:
            return Jog(start[0], sign)

        request = Request((module,), False, params["VM"], params["PR2"], lay=lay, jog=True,
                          label=st.text)
        self.motion.issue(request)
        self.motion.planned[module] = None

    def jog_stop(self, st: Statement) -> None:
        module = self.prefixed_module(st)
        self.motion.stop_jog(module)

    def home(self, st: Statement) -> None:
        module = self.p2p_module(st)
        self.check_motion_allowed((module,))
        machine_zero = self.offsets[module]

        def done() -> None:
            self.motion.coords[module] = 0.0
            if self.motion.last.get(module) is request:
                self.motion.planned[module] = 0.0
            self.offsets[module] = 0.0

        request = self.single_request(module, lambda _start: machine_zero, st.text)
        request.on_end = done
        self.motion.issue(request)
        if self.motion.last.get(module) is request:
            self.motion.planned[module] = None

    def coordinate_set(self, st: Statement) -> None:
        module = self.prefixed_module(st)
        value = self.value(st.operands[0])
        before = self.motion.position(module)
        self.motion.set_position(module, value)
        self.offsets[module] += value - before
        self.touched.add(module)

    def hold(self, st: Statement) -> None:
        module = self.prefixed_module(st)
        on = st.name.endswith("HON")
        if not on and self.motion.busy((module,)):
            raise RunError(f"HOFF while T{module} moves")
        self.held[module] = on

    def reset_module(self, st: Statement) -> None:
        module = self.prefixed_module(st)
        if self.motion.busy((module,)):
            raise RunError(f"RESET while T{module} moves")
        self.held[module] = True

    # ---------------------------------------------------------------------- outputs
    def output(self, st: Statement) -> None:
        index = st.operands[0].index - 1
        if st.name in ("SET", "ISET"):
            self.outputs[index] = True
        elif st.name in ("CLR", "ICLR"):
            self.outputs[index] = False
            self.pulse_until[index] = 0.0
        else:
            self.outputs[index] = not self.output_level(index)
            self.pulse_until[index] = 0.0

    def output_level(self, index: int) -> bool:
        return self.outputs[index] or self.clock < self.pulse_until[index]

    def pulse(self, st: Statement) -> None:
        index = st.operands[0].index - 1
        unit = float(self.profile.fact("program", "pls_unit_ms")) / 1000
        self.pulse_until[index] = self.clock + self.value(st.operands[1]) * unit

    def output_all(self, st: Statement) -> None:
        mask = int(self.value(st.operands[0]))
        self.outputs = [bool(mask >> i & 1) for i in range(len(self.outputs))]

    # ----------------------------------------------------------------- control flow
    def jump(self, st: Statement) -> None:
        self.pc = self.resolve(st.operands[-1])

    def jump_if(self, condition: bool, st: Statement) -> None:
        if condition:
            self.jump(st)

    def input_on(self, operand: Operand) -> bool:
        return self.inputs[int(self.value(operand)) - 1]

    def jump_input(self, st: Statement) -> None:
        on = self.input_on(st.operands[0])
        self.jump_if(on if st.name == "JI" else not on, st)

    def jump_zero(self, st: Statement) -> None:
        zero = self.value(st.operands[0]) == 0
        self.jump_if(zero if st.name == "JZ" else not zero, st)

    def jump_compare(self, st: Statement) -> None:
        c, var = self.value(st.operands[0]), self.value(st.operands[1])
        holds = {"JE": var == c, "JNE": var != c, "JG": var > c, "JNG": var <= c}[st.name]
        self.jump_if(holds, st)

    def jump_timed(self, st: Statement) -> None:
        """JTI/JNTI: jump if the input is (or becomes, within tm ms) on/off; else go on."""
        want_on = st.name == "JTI"
        unit = float(self.profile.fact("program", "timeout_unit_ms")) / 1000
        end = self.clock + self.value(st.operands[1]) * unit
        target = self.resolve(st.operands[2])

        def done() -> bool:
            if self.input_on(st.operands[0]) == want_on:
                self.pc = target
                return True
            return self.clock >= end - CLOSE

        self.wait = Wait(st.text, done, lambda: end)

    def call(self, st: Statement) -> None:
        target = self.resolve(st.operands[0])
        self.stack.append(self.pc)
        self.pc = target

    def ret(self, _st: Statement) -> None:
        if not self.stack:
            self.stop()
            return
        self.pc = self.stack.pop()
        for event in self.events:
            if event.depth is not None and len(self.stack) < event.depth:
                event.depth = None

    def wait_input(self, st: Statement) -> None:
        want_on = st.name == "WI"
        self.wait = Wait(st.text, lambda: self.input_on(st.operands[0]) == want_on,
                         lambda: INF)

    def wait_time(self, st: Statement) -> None:
        end = self.clock + self.value(st.operands[0]) / 1000
        self.wait = Wait(st.text, lambda: self.clock >= end - CLOSE, lambda: end)

    def wait_done(self, st: Statement) -> None:
        modules = None if st.prefix is None else (self.prefixed_module(st),)
        self.wait = Wait(st.text, lambda: not self.motion.busy(modules), self.motion.next_event)

    def wait_logical(self, st: Statement) -> None:
        module = self.logical_module(WAIT_AXIS[st.name])
        self.wait = Wait(st.text, lambda: not self.motion.busy((module,)),
                         self.motion.next_event)

    def set_event(self, st: Statement) -> None:
        event = self.events[st.operands[0].index - 1]
        event.variable = st.operands[2].index if st.operands[2].kind == "nvar" else None
        if st.operands[2].kind != "nvar":
            raise RunError("SET EV watches a scalar integer variable Nn")
        event.last = False

    def on_event(self, st: Statement) -> None:
        self.events[st.operands[0].index - 1].handler = self.resolve(st.operands[1])

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

    def buffer_control(self, st: Statement) -> None:
        if st.name == "PZ":
            self.motion.dispatch_paused = True
        elif st.name == "REDO":
            self.motion.dispatch_paused = False
            self.motion.advance(self.clock)
        else:
            self.motion.clear_buffer()

    def path_control(self, st: Statement) -> None:
        if st.name == "TAPZ":
            self.motion.pause_path()
        elif st.name == "TAREDO":
            self.motion.resume_path()
        elif st.name == "TAUPZ":
            self.motion.drop_paused()
        else:
            self.motion.emergency_stop()

    def continuous_mode(self, st: Statement) -> None:
        self.params["CM"] = int(self.value(st.operands[0]))

    def out(self, st: Statement) -> None:
        operand = st.operands[0]
        text = operand.text[1:-1] if operand.kind == "string" else format_number(
            self.value(operand))
        self.printed.append(text)

    def data(self, st: Statement) -> None:
        self.store(st.operands[0], self.value(st.operands[1]))
        self.check_events()

    def get_number(self, st: Statement) -> None:
        target = st.operands[0]

        def done() -> bool:
            if not self.host_lines:
                return False
            text = self.host_lines.popleft().strip()
            try:
                number = float(text)
            except ValueError:
                raise RunError(f"{st.name} expected a number from the host, got {text!r}"
                               ) from None
            self.store(target, number)
            return True

        self.wait = Wait(st.text, done, lambda: INF)

    # ---------------------------------------------------------------------- queries
    def query(self, st: Statement) -> str:
        name = st.name
        if name in ("NS", "RS") or (name[0] in "NR" and name[1:].isdigit()):
            if st.operands:
                return format_number(self.value(st.operands[0]))
            kind = "nvar" if name[0] == "N" else "rvar"
            return format_number(self.value(Operand(kind, name, st.span, int(name[1:]))))
        module = 0 if st.prefix is None else st.prefix
        if name == "PE":
            return format_number(self.motion.position(module))
        if name == "VM":
            return format_number(self.module_params[module]["VM"])
        if name == "IN":
            return "1" if self.input_on(st.operands[0]) else "0"
        if name == "ST":
            return self.status()
        if name == "VER":
            return "mplang virtual CSIM 1"
        if name == "ERR":
            return "0" if self.error is None else "1"
        if name in ("TM", "TIME"):
            return format_number(math.floor(self.clock - self.tm_base))
        raise NotModelled(f"?{name} is not modelled by the virtual CSIM")

    def status(self) -> str:
        if self.error is not None:
            return "ERROR"
        if self.motion.path_paused:
            return "PAUSE"
        if self.running:
            return "WAIT" if self.wait is not None else "RUN"
        return "MOVE" if self.motion.busy() else "IDLE"

    # --------------------------------------------------------------------- reports
    def variables(self) -> dict[str, float]:
        found: dict[str, float] = {}
        for i, value in enumerate(self.n):
            if value:
                found[f"N{i}"] = value
        for i, real in enumerate(self.r):
            if real:
                found[f"R{i}"] = _plain(real)
        for i, value in enumerate(self.ns):
            if value:
                found[f"NS({i})"] = value
        for i, real in enumerate(self.rs):
            if real:
                found[f"RS({i})"] = _plain(real)
        return found

    def axes(self) -> dict[str, dict[str, float]]:
        report = {}
        for module in self.reported_modules():
            position = _plain(self.motion.position(module))
            report[self.axis_name(module)] = {"lp": position, "ep": position}
        return report


def _always(_previous: Request, _new: Request) -> bool:
    return True


def _integral_operand(operand: Operand) -> bool:
    return operand.is_integer_variable or operand.integral


def _plain(value: float) -> float:
    """A position or real for JSON: an int when whole (within 1e-6), else rounded to 6."""
    rounded = round(value, 6)
    if rounded == int(rounded):
        return int(rounded)
    return rounded
