"""std:circle.mp on the virtual controller: the sampled tool path stays on the circle, turns
the requested way the requested number of times and ends where it started."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest
from library_support import Variables, X, Y, build, consts, load, move_to, trace

CENTRE = (0, 8000)  # relative to the start: the start is the circle's lowest point
START = (5000, 7000)


def circles(laps: int, clockwise: int) -> tuple[Variables, list[tuple[int, int]]]:
    result = build(consts(STD_CIRCLE_AXIS1=X, STD_CIRCLE_AXIS2=Y, STD_CIRCLE_CX=CENTRE[0],
                          STD_CIRCLE_CY=CENTRE[1], STD_CIRCLE_VSV=1000, STD_CIRCLE_VV=20_000,
                          STD_CIRCLE_VA=100_000) + """
INCLUDE "std:circle.mp"

MP 100 main
    SET_MAX_V XY, 80000
END MP
""")
    vc = load(result)
    move_to(vc, {X: START[0], Y: START[1]})
    variables = Variables(result, vc)
    variables["std_circle_laps"], variables["std_circle_cw"] = laps, clockwise
    return variables, trace(vc, result, "std_circle", (X, Y))


@pytest.mark.parametrize(("clockwise", "turn"), [(1, -1), (0, 1)])
def test_laps_stay_on_the_circle_and_turn_the_right_way(clockwise: int, turn: int) -> None:
    variables, samples = circles(2, clockwise)
    cx, cy = START[0] + CENTRE[0], START[1] + CENTRE[1]
    radius = math.hypot(*CENTRE)
    angles = []
    for x, y in samples:
        assert abs(math.hypot(x - cx, y - cy) - radius) <= 2
        angles.append(math.atan2(y - cy, x - cx))
    swept = sum((b - a + math.pi) % (2 * math.pi) - math.pi for a, b in pairwise(angles))
    assert swept == pytest.approx(turn * 2 * 2 * math.pi, abs=1e-3)  # CCW = increasing angle
    assert samples[-1] == START
    assert variables["std_circle_laps_done"] == 2
