"""The CSIM motion model: profiles, paths, the buffer and blending."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from mplang.csim.motion import Arc, Line, MotionModel, Request, plan, plan_brake

SPEED = st.floats(1, 1e5)
LENGTH = st.floats(0.001, 1e6)


@given(st.floats(0, 2e5), LENGTH, SPEED, SPEED)
def test_a_plan_ends_at_rest_on_its_length_and_never_exceeds_its_speeds(
        v0: float, length: float, vmax: float, accel: float) -> None:
    profile = plan(v0, length, vmax, accel)
    assert profile.state(profile.duration) == (length, 0.0)
    dt = profile.duration * 1e-9
    s_end, v_end = profile.state(profile.duration - dt)
    assert math.isclose(s_end, length, rel_tol=1e-6, abs_tol=1e-6)
    braking = max(accel, v0 * v0 / (2 * length))
    assert 0 <= v_end <= braking * dt * 1.001 + 1e-9  # the speed falls continuously to 0
    previous = 0.0
    for k in range(1, 50):
        s, v = profile.state(profile.duration * k / 50)
        assert s >= previous - 1e-6 * length
        assert -1e-6 <= v <= max(v0, vmax) * (1 + 1e-9) + 1e-9
        previous = s


def test_trapezoid_numbers() -> None:
    profile = plan(0, 10000, 1000, 10000)
    assert math.isclose(profile.duration, 10.1)  # 0.1 s up, 9.9 s cruise, 0.1 s down
    assert math.isclose(profile.state(5.05)[0], 5000)
    assert plan_brake(1000, 10000).length == 50


def test_arc_by_centre_and_angle() -> None:
    arc = Arc((0.0, 0.0), (100.0, 100.0), math.radians(360))
    assert math.isclose(arc.length, 2 * math.pi * math.hypot(100, 100))
    end = arc.end
    assert math.isclose(end[0], 0, abs_tol=1e-9) and math.isclose(end[1], 0, abs_tol=1e-9)
    quarter = Arc((100.0, 0.0), (0.0, 0.0), math.radians(-90))
    assert all(math.isclose(a, b, abs_tol=1e-9) for a, b in zip(quarter.end, (0, -100),
                                                                strict=True))
    helix = Arc((0.0, 0.0, 0.0), (50.0, 0.0), math.radians(360), 30.0)
    assert math.isclose(helix.end[2], 30) and helix.shape == "helix"


def line_request(modules: tuple[int, ...], target: tuple[float, ...]) -> Request:
    return Request(modules, len(modules) > 1, 1000.0, 10000.0,
                   lay=lambda start: Line(start, target))


def test_the_buffer_runs_requests_per_module_in_order() -> None:
    model = MotionModel(8)
    model.issue(line_request((0,), (100.0,)))
    model.issue(line_request((0,), (300.0,)))
    model.issue(line_request((1,), (50.0,)))
    assert len(model.active) == 2 and len(model.queue) == 1
    model.advance(10.0)
    assert model.coords[:2] == [300.0, 50.0] and not model.busy()


def test_blending_joins_segments_without_stopping() -> None:
    blended = MotionModel(8)
    separate = MotionModel(8)
    for model, blend in ((blended, lambda a, b: True), (separate, None)):
        model.issue(line_request((0, 1), (100.0, 0.0)), blend)
        model.issue(line_request((0, 1), (100.0, 100.0)), blend)
    assert len(blended.active) == 1 and not blended.queue
    blended.advance(0.15)
    assert blended.velocity(0) > 900  # passing the corner region at speed
    ends = []
    for model in (blended, separate):
        model.advance(100)
        ends.append(tuple(model.coords[:2]))
    assert ends == [(100.0, 100.0), (100.0, 100.0)]
