"""The CSIM's motion commands: point-to-point and logical-axis moves, coordinated lines
and arcs, jogs, homing, coordinates, hold/reset, and the motion buffer's pause and stop.

Each issues a `Request` to the motion model of mplang/csim/motion.py; mixed into the
`Machine` of mplang/csim/machine.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mplang.csim.machine_state import (
    CLOSE,
    LOGICAL,
    MOVE_AXIS,
    MachineState,
    RunError,
    format_number,
)
from mplang.csim.motion import Arc, Jog, Line, Request, Segment, angle_between
from mplang.csim.syntax import Statement


class MotionCommands(MachineState):
    """The commands that move (or stop, or hold) the modules."""

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


def _always(_previous: Request, _new: Request) -> bool:
    return True
