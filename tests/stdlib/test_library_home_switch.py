"""std:home_switch.mp: near-home and home switch search (steps 1, 2, 4) on the virtual
controller. Expected end points come from the sensor layout: searching in the negative
direction, step 2 stops exactly on the upper edge of HOME, step 4 moves the offset back up;
the end point becomes LP = EP = 0."""

from __future__ import annotations

from functools import cache

from hypothesis import assume, given, settings
from hypothesis import strategies as st
from library_support import (
    NO_SENSORS,
    U,
    Variables,
    X,
    Y,
    Z,
    build,
    consts,
    ep,
    load,
    lp,
    machine,
    move_to,
    run,
)

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors

OFFSET = 5000


@cache
def program(direction: int = 2, near: int = 1, before: str = "") -> BuildResult:
    """The axes' profile, `before`, then std_home_switch (the test sets the mask)."""
    return build(consts(STD_HOME_SWITCH_DIR=direction, STD_HOME_SWITCH_NEAR=near,
                        STD_HOME_SWITCH_HV=2000, STD_HOME_SWITCH_OFFSET=OFFSET) + f"""
INCLUDE "std:home_switch.mp"

MP 100 main
    SET_MAX_V XYZU, 80000
    SET_SV XYZU, 1000
    SET_V XYZU, 20000
    SET_A XYZU, 200000
    {before}
    CALL std_home_switch
END MP
""")


X_MACHINE = AxisSensors(near_home=(-30_000, -10_000), home=(-20_000, -19_000),
                        index_period=None)
Y_MACHINE = AxisSensors(near_home=(5_000, 40_000), home=(20_000, 20_500), index_period=None)


def home(mask: int, sensors: dict[int, AxisSensors], result: BuildResult | None = None,
         start: int = 100_000) -> tuple[Variables, float]:
    """Home the axes of `mask`, X and Y starting at `start`; the variables and the run's
    duration."""
    result = result or program()
    vc = load(result, sensors)
    move_to(vc, {X: start, Y: start})
    began = vc.clock
    variables = Variables(result, vc)
    variables["std_home_switch_axes"] = mask
    run(vc, result)
    return variables, vc.clock - began


def test_x_and_y_home_together_and_park_clear_of_their_switches() -> None:
    variables, both = home(X | Y, {0: X_MACHINE, 1: Y_MACHINE})
    vc = variables.vc
    # step 1 stops inside NHOME above HOME; step 2 ends on HOME's upper edge
    assert machine(vc, X) == -19_000 + OFFSET
    assert machine(vc, Y) == 20_500 + OFFSET
    assert [lp(vc, X), ep(vc, X), lp(vc, Y), ep(vc, Y)] == [0, 0, 0, 0]
    assert variables["std_home_switch_error"] == 0
    assert [machine(vc, Z), machine(vc, U)] == [0, 0]  # not in the mask: never moved
    # the two searches run at the same time, not one after the other
    _x_alone, x_time = home(X, {0: X_MACHINE, 1: Y_MACHINE})
    _y_alone, y_time = home(Y, {0: X_MACHINE, 1: Y_MACHINE})
    assert both < x_time + y_time - 5.0
    assert both >= max(x_time, y_time)


def test_only_the_axes_of_the_mask_move() -> None:
    variables, _ = home(Y, {0: X_MACHINE, 1: Y_MACHINE})
    vc = variables.vc
    assert (machine(vc, X), lp(vc, X)) == (100_000, 100_000)
    assert (machine(vc, Y), lp(vc, Y)) == (20_500 + OFFSET, 0)


@settings(max_examples=25, deadline=None)
@given(lo=st.integers(-40_000, 40_000), width=st.integers(0, 3000),
       start=st.integers(-45_000, 60_000), direction=st.sampled_from([1, 2]))
def test_without_near_home_switch_the_search_ends_at_the_home_edge_plus_offset(
        lo: int, width: int, start: int, direction: int) -> None:
    """NEAR = 0: step 2 alone, from in front of HOME or from on it (it leaves it first)."""
    hi = lo + width
    assume(start >= lo if direction == 2 else start <= hi)
    variables, _ = home(X, {0: AxisSensors(near_home=None, home=(lo, hi), index_period=None)},
                        program(direction, 0), start)
    vc = variables.vc
    expected = hi + OFFSET if direction == 2 else lo - OFFSET
    assert machine(vc, X) == expected
    assert (lp(vc, X), ep(vc, X), variables["std_home_switch_error"]) == (0, 0, 0)


def test_a_search_that_ends_on_a_limit_reports_the_limit() -> None:
    """No HOME switch: step 2 runs into LIMIT-, backs up to find HOME from the other side
    (the manual's irregular operation) and ends on LIMIT+ with that error (4)."""
    sensors = AxisSensors(limit_plus=120_000, limit_minus=-5_000, near_home=None, home=None,
                          index_period=None)
    variables, _ = home(X, {0: sensors}, program(2, 0))
    vc = variables.vc
    assert variables["std_home_switch_error"] == 4
    assert machine(vc, X) == 120_000
    assert lp(vc, X) == 120_000  # a failed search does not clear the counters


def test_the_error_code_is_that_of_this_search() -> None:
    """An error latched before (a stop command: 256) is cleared before the search."""
    result = program(before="FIXED_MOVE X, 1000\n    STOP_SUDDENLY X\n    STOP_WAIT X")
    variables, _ = home(X, {0: X_MACHINE, 1: NO_SENSORS}, result)
    assert variables["std_home_switch_error"] == 0
    assert machine(variables.vc, X) == -19_000 + OFFSET
