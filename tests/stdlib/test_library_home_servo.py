"""std:home_servo.mp: the four-step search with the encoder Z phase on the virtual controller.
With the switches searched in the negative direction, step 2 ends on HOME's upper edge, step
3 runs up to the next Z pulse and step 4 adds the offset: the manual's SET_HOME_MODE example
(X, 2, 2, 1, 1, 3500) as a library call."""

from __future__ import annotations

from functools import cache

from hypothesis import example, given, settings
from hypothesis import strategies as st
from library_support import Variables, X, Y, build, consts, ep, load, lp, machine, move_to, run

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors

OFFSET = 3500  # the manual's example offset


@cache
def program(near: int = 1) -> BuildResult:
    return build(consts(STD_HOME_SERVO_DIR=2, STD_HOME_SERVO_NEAR=near,
                        STD_HOME_SERVO_HV=500, STD_HOME_SERVO_OFFSET=OFFSET) + """
INCLUDE "std:home_servo.mp"

MP 100 main
    SET_MAX_V XY, 80000
    SET_SV XY, 1000
    SET_V XY, 20000
    SET_A XY, 200000
    CALL std_home_servo
END MP
""")


def next_index(position: int, period: int, phase: int) -> int:
    """The first Z pulse above `position`."""
    return position + 1 + (phase - position - 1) % period


def home(mask: int, sensors: dict[int, AxisSensors], near: int = 1,
         start: int = 100_000) -> Variables:
    result = program(near)
    vc = load(result, sensors)
    move_to(vc, {X: start, Y: start})
    variables = Variables(result, vc)
    variables["std_home_servo_axes"] = mask
    run(vc, result)
    return variables


MANUAL_MACHINE = AxisSensors(limit_plus=500_000, limit_minus=-500_000,
                             near_home=(-30_000, -10_000), home=(-20_000, -19_000),
                             index_period=4000, index_offset=100)


def test_manual_example_machine_and_a_second_axis_home_together() -> None:
    other = AxisSensors(near_home=(0, 50_000), home=(30_000, 31_000), index_period=2500,
                        index_offset=7)
    variables = home(X | Y, {0: MANUAL_MACHINE, 1: other})
    vc = variables.vc
    assert next_index(-19_000, 4000, 100) == -15_900
    assert machine(vc, X) == -15_900 + OFFSET
    assert machine(vc, Y) == next_index(31_000, 2500, 7) + OFFSET
    assert [lp(vc, X), ep(vc, X), lp(vc, Y), ep(vc, Y)] == [0, 0, 0, 0]
    assert variables["std_home_servo_error"] == 0


def test_without_near_home_switch_steps_2_to_4_alone() -> None:
    variables = home(X, {0: MANUAL_MACHINE}, near=0, start=-12_000)
    assert machine(variables.vc, X) == -15_900 + OFFSET
    assert variables["std_home_servo_error"] == 0


@settings(max_examples=25, deadline=None)
@given(hi=st.integers(-30_000, 30_000), period=st.integers(50, 5000), phase=st.integers(0, 5000))
@example(hi=-19_000, period=4000, phase=1000)  # a Z pulse right on the HOME edge
def test_the_zero_is_the_next_z_pulse_after_the_home_edge_or_the_home_error(
        hi: int, period: int, phase: int) -> None:
    sensors = AxisSensors(near_home=None, home=(hi - 500, hi), index_period=period,
                          index_offset=phase)
    variables = home(X, {0: sensors}, near=0, start=40_000)
    vc = variables.vc
    if (hi - phase) % period == 0:  # Z and HOME both active when step 3 starts
        assert variables["std_home_servo_error"] == 128
        assert machine(vc, X) == hi
    else:
        assert variables["std_home_servo_error"] == 0
        assert machine(vc, X) == next_index(hi, period, phase) + OFFSET
        assert (lp(vc, X), ep(vc, X)) == (0, 0)
