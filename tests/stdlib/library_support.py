"""Shared helpers of the tests of the `.mp` routine library (tests/stdlib/test_library_*.py).

A test writes a small program that INCLUDEs a library file with its CONSTs, builds it, loads
every program into a fresh virtual controller (with the simulated machine it needs), calls
one MP and looks at positions and at the library's declared variables by name.
"""

from __future__ import annotations

from mplang.m8194h.compiler import BuildResult, compile_source
from mplang.m8194h.sim.axis_io import AxisSensors
from mplang.m8194h.sim.controller import VirtualController

X, Y, Z, U = 1, 2, 4, 8
AXIS_BITS = (X, Y, Z, U)
NO_SENSORS = AxisSensors(near_home=None, home=None, index_period=None)
TEMPORARY_POOL = range(500, 512)  # the compiler's default temporaries, VAR500..VAR511


def consts(**values: int) -> str:
    """CONST lines for the including project."""
    return "".join(f"CONST {name} = {value}\n" for name, value in values.items())


def build(source: str, name: str = "main.mp") -> BuildResult:
    """Build `source` and insist on a clean build: no errors and no warnings, as a library
    routine must build. (`std:` includes do not depend on where the source lives.)"""
    result = compile_source(source, name)
    assert [d.render() for d in result.diagnostics] == []
    return result


def load(result: BuildResult, sensors: dict[int, AxisSensors] | None = None
         ) -> VirtualController:
    """A fresh controller holding every program of the build; `sensors` per axis index
    (default: no sensors at all, so nothing switches unless a test says so)."""
    vc = VirtualController(word_order=result.word_order)
    for image in result.programs:
        assert vc.load_frames(image.program.kind, image.placement.slot, image.frames) is None
    for i in range(4):
        vc.motion.io.set_sensors(i, (sensors or {}).get(i, NO_SENSORS), 0.0)
    return vc


def slot(result: BuildResult, name: str) -> int:
    """Where the linker placed the program `name`."""
    (found,) = [p.placement.slot for p in result.programs if p.program.name == name]
    return found


def run(vc: VirtualController, result: BuildResult, program: str = "main",
        max_time: float = 600.0) -> None:
    """Call `program` and run until it (and the motion it started) is finished."""
    vc.call(slot(result, program))
    outcome = vc.run(max_time=max_time)
    assert outcome.finished, outcome.error


class Variables:
    """The declared variables of a build, read from a controller by name."""

    def __init__(self, result: BuildResult, vc: VirtualController) -> None:
        self.index = {v.name.lower(): v.index for v in result.variables}
        self.vc = vc

    def __getitem__(self, name: str) -> int:
        return self.vc.vars[self.index[name.lower()]]

    def __setitem__(self, name: str, value: int) -> None:
        self.vc.vars[self.index[name.lower()]] = value


def lp(vc: VirtualController, axis: int) -> int:
    return vc.motion.lp(axis, vc.clock)


def ep(vc: VirtualController, axis: int) -> int:
    return vc.motion.ep(axis, vc.clock)


def machine(vc: VirtualController, axis: int) -> int:
    """The axis position in the frame of its sensors (SET_LP and homing do not move it)."""
    return vc.motion.io.machine_position(AXIS_BITS.index(axis), vc.clock)


def move_to(vc: VirtualController, positions: dict[int, int]) -> None:
    """Drive axes to absolute positions before the test's program runs, as a host's
    real-time moves would (with the controller's power-on profile)."""
    for axis, position in positions.items():
        vc.motion.abs_move(axis, position, vc.clock)
    end = vc.motion.idle_at(sum(positions), vc.clock)
    assert end is not None
    vc.advance(end)


def trace(vc: VirtualController, result: BuildResult, program: str, axes: tuple[int, int],
          period: float = 0.005, max_time: float = 600.0) -> list[tuple[int, int]]:
    """Call `program` and sample the positions of two axes every `period` seconds of
    simulated time until it and its motion are finished."""
    vc.call(slot(result, program))
    samples = [(lp(vc, axes[0]), lp(vc, axes[1]))]
    limit = vc.clock + max_time
    while vc.stack or vc.motion.busy(axes[0] | axes[1], vc.clock):
        assert vc.clock < limit, "the program does not finish"
        vc.advance(vc.clock + period)
        samples.append((lp(vc, axes[0]), lp(vc, axes[1])))
    assert vc.error is None, vc.error
    return samples
