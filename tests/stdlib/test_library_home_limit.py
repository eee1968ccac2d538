"""std:home_limit.mp: homing on a limit switch (HOME_LIMIT 1) on the virtual controller.
Step 2 ends exactly on the switch (engaged at and below LIMIT-), step 4 moves the offset away
from it; the end point becomes LP = EP = 0."""

from __future__ import annotations

from library_support import Variables, X, Y, build, consts, ep, load, lp, machine, move_to, run

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors

OFFSET = 1000
PROFILE = """
    SET_MAX_V XY, 80000
    SET_SV XY, 1000
    SET_V XY, 20000
    SET_A XY, 200000
"""


def program(extra: str = "", calls: str = "CALL std_home_limit") -> BuildResult:
    return build(consts(STD_HOME_LIMIT_DIR=2, STD_HOME_LIMIT_HV=5000,
                        STD_HOME_LIMIT_OFFSET=OFFSET) + extra + f"""
INCLUDE "std:home_limit.mp"

MP 100 main
{PROFILE}
    {calls}
END MP
""")


def sensors(limit_minus: int, home: tuple[int, int] | None = None) -> AxisSensors:
    return AxisSensors(limit_minus=limit_minus, near_home=None, home=home, index_period=None)


def test_x_and_y_home_on_their_minus_limits() -> None:
    result = program()
    vc = load(result, {0: sensors(-3000), 1: sensors(-50_000)})
    move_to(vc, {X: 20_000, Y: 7_000})
    variables = Variables(result, vc)
    variables["std_home_limit_axes"] = X | Y
    run(vc, result)
    assert (machine(vc, X), machine(vc, Y)) == (-3000 + OFFSET, -50_000 + OFFSET)
    assert [lp(vc, X), ep(vc, X), lp(vc, Y), ep(vc, Y)] == [0, 0, 0, 0]
    assert variables["std_home_limit_error"] == 0


def test_an_axis_standing_on_the_switch_leaves_it_and_searches_it_again() -> None:
    result = program()
    vc = load(result, {0: sensors(-3000)})
    move_to(vc, {X: -3000})  # stops on the switch, LIMIT- latched: the routine clears it
    assert vc.motion.io.error_code(X, vc.clock) == 8
    variables = Variables(result, vc)
    variables["std_home_limit_axes"] = X
    run(vc, result)
    assert machine(vc, X) == -3000 + OFFSET
    assert variables["std_home_limit_error"] == 0


def test_the_switch_routine_switches_limit_as_home_off_again() -> None:
    """Home X on its limit, then on its HOME switch: std_home_switch must search HOME (it
    lies above, so the search first runs into the limit and backs up through HOME), not
    stop on the limit that std_home_limit made the home signal."""
    result = program(
        consts(STD_HOME_SWITCH_DIR=2, STD_HOME_SWITCH_NEAR=0, STD_HOME_SWITCH_HV=5000,
               STD_HOME_SWITCH_OFFSET=500) + 'INCLUDE "std:home_switch.mp"\n',
        "std_home_limit_axes = 1\n    CALL std_home_limit\n"
        "    std_home_switch_axes = 1\n    CALL std_home_switch")
    vc = load(result, {0: sensors(-30_000, home=(-10_000, -9_000))})
    run(vc, result)
    variables = Variables(result, vc)
    assert variables["std_home_limit_error"] == 0
    assert variables["std_home_switch_error"] == 0
    assert machine(vc, X) == -9_000 + 500
