"""std:home_index.mp: homing on the encoder Z phase alone on the virtual controller. The Z
pulse is engaged for `width` pulses once per period: searching upwards the axis stops on a
pulse's lower edge, downwards on its upper edge, then moves the offset on."""

from __future__ import annotations

from functools import cache

import pytest
from library_support import (
    AXIS_BITS,
    U,
    Variables,
    X,
    Y,
    Z,
    build,
    consts,
    load,
    lp,
    machine,
    move_to,
    run,
)

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors

OFFSET = 200


@cache
def program(direction: int) -> BuildResult:
    return build(consts(STD_HOME_INDEX_DIR=direction, STD_HOME_INDEX_HV=2000,
                        STD_HOME_INDEX_OFFSET=OFFSET) + """
INCLUDE "std:home_index.mp"

MP 100 main
    SET_MAX_V XYZU, 80000
    SET_SV XYZU, 1000
    SET_V XYZU, 20000
    SET_A XYZU, 200000
    CALL std_home_index
END MP
""")


def index(phase: int = 0, home: tuple[int, int] | None = None) -> AxisSensors:
    """Z on at phase + k * 1000 .. + 9."""
    return AxisSensors(near_home=None, home=home, index_period=1000, index_width=10,
                       index_offset=phase)


def home(direction: int, mask: int, machines: dict[int, AxisSensors],
         starts: dict[int, int]) -> Variables:
    result = program(direction)
    vc = load(result, machines)
    move_to(vc, starts)
    variables = Variables(result, vc)
    variables["std_home_index_axes"] = mask
    run(vc, result)
    return variables


@pytest.mark.parametrize(("direction", "start", "expected"), [
    (1, 2500, 3000 + OFFSET),    # up to the lower edge of the pulse at 3000..3009
    (2, 2500, 2009 - OFFSET),    # down to the upper edge of the pulse at 2000..2009
    (1, 3004, 4000 + OFFSET),    # standing on a pulse: the next one
    (2, 3004, 2009 - OFFSET),
])
def test_one_axis_ends_offset_from_the_next_z_pulse(direction: int, start: int,
                                                     expected: int) -> None:
    variables = home(direction, X, {0: index()}, {X: start})
    assert machine(variables.vc, X) == expected
    assert lp(variables.vc, X) == 0
    assert variables["std_home_index_error"] == 0


def test_four_axes_home_at_once_each_on_its_own_pulse() -> None:
    phases = {X: 0, Y: 250, Z: 500, U: 999}
    machines = {AXIS_BITS.index(axis): index(phase) for axis, phase in phases.items()}
    variables = home(1, X | Y | Z | U, machines, {axis: 1100 for axis in phases})
    vc = variables.vc
    for axis, phase in phases.items():
        first = 1100 + (phase - 1100) % 1000  # the first pulse start above 1100
        assert machine(vc, axis) == first + OFFSET, axis
        assert lp(vc, axis) == 0
    assert variables["std_home_index_error"] == 0


def test_home_active_on_a_z_pulse_is_the_home_error() -> None:
    variables = home(1, X, {0: index(home=(-100, 5000))}, {X: 3004})
    assert variables["std_home_index_error"] == 128
    assert machine(variables.vc, X) == 3004  # the search did not move
