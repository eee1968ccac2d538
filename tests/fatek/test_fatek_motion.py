"""The PLC's speed profiles: constant-slope ramps from the start/stop speed, DRVC chains that
run each segment at its own speed, and (hypothesis) every plan ends exactly on its length
without ever running faster than a segment allows."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.fatek.motion import INF, Leg, PathProfile, Segment, plan

SLOPE = 460_000 / 5.0  # FUN141 defaults: parameter 4 reached in parameter-8 time (FB 1597)


def speed_at_distance(profile: PathProfile, distance: float) -> float:
    return profile.v(profile.time_at(distance))


def test_a_long_move_ramps_cruises_and_stops_on_its_target() -> None:
    profile, _ = plan([Segment(100_000, 10_000)], 0.0, 141, 141, SLOPE, SLOPE)
    assert profile.s(profile.end) == 100_000
    ramp = (10_000 - 141) / SLOPE
    cruise = (100_000 - 2 * (10_000**2 - 141**2) / (2 * SLOPE)) / 10_000
    assert profile.end == pytest.approx(2 * ramp + cruise)
    assert profile.v(profile.end / 2) == pytest.approx(10_000)


def test_a_short_move_is_a_triangle() -> None:
    profile, _ = plan([Segment(100, 50_000)], 0.0, 141, 141, SLOPE, SLOPE)
    peak = max(profile.v(p.t0 + p.duration / 2) for p in profile.phases)
    assert peak < 50_000
    assert profile.s(profile.end) == 100


def test_the_drvc_example_runs_each_segment_at_its_speed() -> None:
    # FB 988-997: 20000 at 10 kHz, 60000 at 50 kHz, 5000 at 3 kHz, one continuous run
    segments = [Segment(20_000, 10_000), Segment(60_000, 50_000), Segment(5_000, 3_000)]
    profile, bounds = plan(segments, 0.0, 141, 141, SLOPE, SLOPE)
    assert bounds == [20_000, 80_000, 85_000]
    assert profile.s(profile.end) == 85_000
    assert speed_at_distance(profile, 10_000) == pytest.approx(10_000)
    assert speed_at_distance(profile, 50_000) == pytest.approx(50_000)
    assert speed_at_distance(profile, 80_000) == pytest.approx(3_000)  # slowed down before it
    assert speed_at_distance(profile, 82_000) == pytest.approx(3_000)
    assert speed_at_distance(profile, 20_000) == pytest.approx(10_000)  # speeds up after it


def test_a_continuous_run_never_ends() -> None:
    profile, _ = plan([Segment(INF, 2_000)], 1.0, 141, 141, SLOPE, SLOPE)
    assert profile.end == INF
    assert profile.v(100.0) == pytest.approx(2_000)
    cut = profile.cut(3.0)
    assert cut.end == 3.0 and cut.length == pytest.approx(profile.s(3.0))


def test_zero_ramp_time_means_instant_speed_changes() -> None:
    profile, _ = plan([Segment(1_000, 500)], 0.0, 141, 141, INF, INF)
    assert profile.end == pytest.approx(2.0)


def test_a_leg_maps_the_path_onto_axes() -> None:
    profile, _ = plan([Segment(5_000, 1_000)], 0.0, 0.0, 0.0, INF, INF)
    leg = Leg(profile, (10.0, 0.0, 0.0, 0.0), {0: -0.6, 1: 0.8}, {0: -2990, 1: 4000})
    assert leg.position(0, 2.5) == pytest.approx(10 - 0.6 * 2_500)
    assert leg.position(1, leg.t_end) == 4000
    assert leg.time_at_position(1, 2_000) == pytest.approx(2.5)
    assert leg.time_at_position(1, -5) == INF


segments = st.lists(st.builds(Segment, st.integers(1, 200_000).map(float),
                              st.integers(1, 921_600).map(float)), min_size=1, max_size=8)
slopes = st.one_of(st.just(INF), st.floats(100.0, 5e6))


@settings(max_examples=300, deadline=None)
@given(segments, st.floats(0.0, 1_000_000.0), st.floats(0.0, 2_000.0), slopes, slopes)
def test_a_plan_ends_on_its_length_and_respects_every_segments_speed(
        chain: list[Segment], entry: float, exit_speed: float, accel: float,
        decel: float) -> None:
    profile, bounds = plan(chain, 0.0, entry, exit_speed, accel, decel)
    total = sum(s.length for s in chain)
    assert bounds[-1] == pytest.approx(total)
    assert profile.s(profile.end) == pytest.approx(total)
    previous_s, previous_t = 0.0, 0.0
    for phase in profile.phases:
        assert phase.t0 == pytest.approx(previous_t)
        assert phase.s0 == pytest.approx(previous_s, abs=1e-6 * total + 1e-6)
        assert phase.v0 >= -1e-6 and phase.v(phase.t1) >= -1e-6
        previous_s, previous_t = phase.s(phase.t1), phase.t1
    start = 0.0
    for index, segment in enumerate(chain):
        end = start + segment.length
        # inside a segment the speed never exceeds its cap, once the entry speed is shed
        middle = profile.time_at((start + end) / 2)
        allowed = segment.cap if index else max(segment.cap, entry)
        assert profile.v(middle) <= allowed * (1 + 1e-9) + 1e-6
        start = end
    assert math.isfinite(profile.end)
