"""std:jog.mp and std:jog_return.mp on the virtual controller.

The axis profile is a symmetric T-curve, SV 1000, A = D 50000 PPS/s, and the jog speed 5000
PPS: reaching it takes 0.08 s and 240 pulses, and a slow stop from it takes the same 240
pulses back down to SV. So a jog of t seconds travels 240 + (t - 0.08) * 5000 + 240 pulses,
plus the few 100 us macro lines between the start and the stop command.
"""

from __future__ import annotations

from functools import cache

import pytest
from library_support import Variables, X, build, consts, load, lp, run, slot

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors

JOG_V, RAMP = 5000, 240
START = 20_000
DI_GROUP, DI_CHANNEL = 8, 2
TIMEOUT_MS = 3000


@cache
def program() -> BuildResult:
    return build(consts(STD_JOG_AXIS=X, STD_JOG_V=JOG_V, STD_JOG_START=START,
                        STD_JOG_DI_GROUP=DI_GROUP, STD_JOG_DI_CHANNEL=DI_CHANNEL,
                        STD_JOG_TIMEOUT_MS=TIMEOUT_MS) + """
INCLUDE "std:jog_return.mp"

MP 100 main
    SET_MAX_V X, 80000
    SET_SV X, 1000
    SET_V X, 40000
    SET_A X, 50000
END MP
""")


def prepared(sensors: AxisSensors | None = None) -> Variables:
    """A controller with the profile set (MP100 run), ready for a library call."""
    result = program()
    vc = load(result, {0: sensors} if sensors else None)
    run(vc, result)
    return Variables(result, vc)


def call(variables: Variables, name: str) -> None:
    result = program()
    run(variables.vc, result, name)


@pytest.mark.parametrize("direction", [1, -1])
def test_a_timed_jog_travels_for_its_time_and_stops_slowly(direction: int) -> None:
    variables = prepared()
    variables["std_jog_dir"], variables["std_jog_ms"] = direction, 1000
    began = variables.vc.clock
    call(variables, "std_jog")
    expected = RAMP + round((1.0 - 0.08) * JOG_V) + RAMP
    travel = variables["std_jog_travel"]
    assert expected <= direction * travel <= expected + 5  # + the lines before the stop
    assert variables["std_jog_from"] == 0
    assert variables["std_jog_to"] == lp(variables.vc, X) == travel
    assert variables.vc.clock - began == pytest.approx(1.0 + 0.08, abs=0.01)


def test_direction_0_waits_without_moving() -> None:
    variables = prepared()
    variables["std_jog_dir"], variables["std_jog_ms"] = 0, 500
    call(variables, "std_jog")
    assert (variables["std_jog_travel"], lp(variables.vc, X)) == (0, 0)


def test_a_limit_switch_ends_the_jog_early() -> None:
    variables = prepared(AxisSensors(limit_plus=3000, near_home=None, home=None,
                                     index_period=None))
    variables["std_jog_dir"], variables["std_jog_ms"] = 1, 5000
    call(variables, "std_jog")
    assert variables["std_jog_to"] == variables["std_jog_travel"] == 3000


@pytest.mark.parametrize("direction", [1, -1])
def test_jog_return_measures_where_the_sensor_switches_and_returns(direction: int) -> None:
    variables = prepared()
    vc = variables.vc
    variables["std_jog_dir"] = direction
    vc.call(slot(program(), "std_jog_return"))
    while variables["std_jog_from"] != START:  # until the axis stands at the start
        vc.advance(vc.clock + 0.01)
    vc.advance(vc.clock + 0.5)  # creeping
    at_switch = lp(vc, X)
    vc.frnet[DI_GROUP] |= 1 << DI_CHANNEL  # the sensor sees the edge now
    vc.touch()
    outcome = vc.run()
    assert outcome.finished, outcome.error
    assert variables["std_jog_found"] == 1
    assert 0 <= direction * (variables["std_jog_edge"] - at_switch) <= 2
    assert RAMP - 2 <= direction * (variables["std_jog_to"] - variables["std_jog_edge"]) <= RAMP + 2
    assert variables["std_jog_travel"] == variables["std_jog_to"] - START
    assert variables["std_jog_from"] == START
    assert lp(vc, X) == START  # back at the start


def test_jog_return_without_a_sensor_gives_up_after_the_timeout() -> None:
    variables = prepared()
    variables["std_jog_dir"] = 1
    call(variables, "std_jog_return")
    expected_edge = START + RAMP + round((TIMEOUT_MS / 1000 - 0.08) * JOG_V)
    assert variables["std_jog_found"] == 0
    assert 0 <= variables["std_jog_edge"] - expected_edge <= 5
    assert lp(variables.vc, X) == START
