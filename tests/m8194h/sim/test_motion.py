"""Tests of the analytic motion model of the virtual M8194H."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.sim.motion import MotionModel

X, Y, Z, U = 1, 2, 4, 8


def _model(mode: int = 0) -> MotionModel:
    m = MotionModel()
    m.set_max_v(15, 80_000)  # speed resolution 10 PPS
    m.set_speed_mode(15, mode)
    m.set_sv(15, 1000)
    m.set_v(15, 10_000)
    m.set_a(15, 100_000)
    m.set_d(15, 50_000)
    m.set_k(15, 2_000_000)
    m.set_l(15, 1_000_000)
    return m


def _samples(t0: float, t1: float, n: int = 60) -> list[float]:
    return [t0 + (t1 - t0) * i / n for i in range(n + 1)]


def test_t_curve_time_matches_formula() -> None:
    m = _model(0)
    m.fixed_move(X, 100_000, 0.0)
    # ramp 1000 -> 10000 at 100000: 0.09 s over (1e8 - 1e6) / 2e5 = 495 pulses, twice; the
    # power-on offset of 8 pulses is run at the start speed after the deceleration
    expected = 0.09 + (100_000 - 8 - 2 * 495) / 10_000 + 0.09 + 8 / 1000
    end = m.idle_at(X, 0.0)
    assert end == pytest.approx(expected)
    assert m.next_event(0.0) == pytest.approx(expected)
    assert m.lp(X, 0.05) == 175  # 1000*0.05 + 100000*0.05**2/2
    assert m.cv(X, 5.0) == pytest.approx(10_000)
    assert m.ca(X, 0.01) == pytest.approx(100_000)
    assert m.ca(X, expected - 0.008 - 0.01) == pytest.approx(-100_000)
    assert m.cv(X, expected - 0.004) == pytest.approx(1000)  # the offset pulses
    assert m.lp(X, expected) == 100_000
    assert not m.busy(X, expected)


def test_t_curve_triangle() -> None:
    m = _model(2)  # A=100000, D=50000
    m.fixed_move(X, 600, 0.0)
    peak = math.sqrt(1000**2 + 2 * (600 - 8) * 100_000 * 50_000 / 150_000)
    assert peak < 10_000
    expected = (peak - 1000) / 100_000 + (peak - 1000) / 50_000 + 8 / 1000
    end = m.idle_at(X, 0.0)
    assert end == pytest.approx(expected)
    assert max(m.cv(X, t) for t in _samples(0.0, end)) == pytest.approx(peak, rel=5e-3)
    assert m.lp(X, end) == 600


@pytest.mark.parametrize("mode", [0, 1])
def test_offset_pulses_run_at_the_start_speed_after_the_deceleration(mode: int) -> None:
    """SET_AO (7.1.8): the deceleration ends `ao` pulses early and the rest runs at SV; the
    move still ends exactly on its target. AO 0 leaves the plain profile."""
    plain = _model(mode)
    plain.set_ao(X, 0)
    plain.fixed_move(X, 20_000, 0.0)
    base = plain.idle_at(X, 0.0)
    m = _model(mode)
    m.set_ao(X, 300)
    m.fixed_move(X, 20_000, 0.0)
    end = m.idle_at(X, 0.0)
    assert base is not None and end is not None and end > base
    assert m.lp(X, end - 0.3) == pytest.approx(19_700, abs=1)  # 300 pulses at SV: 0.3 s
    assert m.cv(X, end - 0.25) == pytest.approx(1000)
    assert m.lp(X, end) == 20_000


def test_vector_offset_pulses_end_a_line_at_the_vector_start_speed() -> None:
    m = _model(0)
    m.axis_assign(X, Y, 0)
    m.set_vector_mode(1)
    m.set_vsv(500)
    m.set_vv(5000)
    m.set_vao(200)
    m.line((3000, 4000), 0.0)  # 5000 pulses of path, the last 200 at 500/s: 0.4 s
    end = m.idle_at(X | Y, 0.0)
    assert end is not None
    assert (m.lp(X, end - 0.4), m.lp(Y, end - 0.4)) == (2880, 3840)
    assert (m.lp(X, end), m.lp(Y, end)) == (3000, 4000)


def test_speed_is_quantised() -> None:
    m = _model(0)
    m.set_v(X, 10_004)  # resolution 10 PPS
    m.fixed_move(X, 1_000_000, 0.0)
    assert m.cv(X, 50.0) == pytest.approx(10_000)


@settings(max_examples=150, deadline=None)
@given(mode=st.integers(0, 3), start=st.integers(-100_000, 100_000),
       value=st.integers(-200_000, 200_000), absolute=st.booleans(),
       axis=st.sampled_from([X, Y, Z, U]))
def test_exact_endpoint_monotonic_and_bounded(mode: int, start: int, value: int,
                                              absolute: bool, axis: int) -> None:
    m = _model(mode)
    m.set_lp(axis, start, 0.0)
    if absolute:
        m.abs_move(axis, value, 1.0)
        target = value
    else:
        m.fixed_move(axis, value, 1.0)
        target = start + value
    end = m.idle_at(axis, 1.0)
    assert end is not None and end >= 1.0
    assert end - 1.0 < 60.0  # finite, plausible
    sign = 1 if target >= start else -1
    last = start
    for t in _samples(1.0, end):
        pos = m.lp(axis, t)
        assert (pos - last) * sign >= 0
        assert m.cv(axis, t) <= 10_000 + 1e-6
        assert min(start, target) <= pos <= max(start, target)
        last = pos
    assert m.lp(axis, end) == target
    assert m.ep(axis, end) == target - start  # SET_LP does not touch the encoder
    assert not m.busy(axis, end)
    assert m.next_event(end) is None


@settings(max_examples=60, deadline=None)
@given(mode=st.sampled_from([1, 3]), dist=st.integers(1, 400))
def test_s_curve_short_moves(mode: int, dist: int) -> None:
    m = _model(mode)
    m.fixed_move(X, dist, 0.0)
    end = m.idle_at(X, 0.0)
    assert end is not None and 0.0 < end < 1.0
    assert m.cv(X, end / 2) >= 1000 - 1e-6
    assert m.lp(X, end) == dist


def test_stop_slowly_from_cruise() -> None:
    m = _model(2)  # D = 50000
    m.fixed_move(X, 1_000_000, 0.0)
    t = 3.0
    ramp = 0.09
    s_now = 495 + (t - ramp) * 10_000
    m.stop(X, t, sudden=False)
    assert m.busy(X, t)
    dist = (10_000**2 - 1000**2) / (2 * 50_000)
    end = m.idle_at(X, t)
    assert end == pytest.approx(t + 9000 / 50_000)
    assert m.lp(X, end) == round(s_now + dist)


def test_stop_slowly_continuous_s_curve() -> None:
    m = _model(3)
    m.continue_move(X, -5000, 0.0)
    assert m.idle_at(X, 0.0) is None
    assert m.next_event(0.0) is None
    assert m.cv(X, 10.0) == pytest.approx(5000)
    p = m.lp(X, 10.0)
    m.stop(X, 10.0, sudden=False)
    end = m.idle_at(X, 10.0)
    assert end == pytest.approx(10.0 + 2 * math.sqrt(4000 / 1_000_000))
    dist = (5000 + 1000) * math.sqrt(4000 / 1_000_000)
    assert abs(m.lp(X, end) - (p - dist)) <= 1


def test_continue_move_speed_change() -> None:
    m = _model(0)
    m.continue_move(Y, 2000, 0.0)
    m.continue_move(Y, 6000, 1.0)
    assert m.cv(Y, 2.0) == pytest.approx(6000)
    m.stop(Y, 2.0, sudden=True)
    assert not m.busy(Y, 2.0)


def test_stop_suddenly_stays_put() -> None:
    m = _model(0)
    m.fixed_move(X | Y, 50_000, 0.0)
    p = m.lp(X, 2.0)
    m.stop(X, 2.0, sudden=True)
    assert not m.busy(X, 2.0)
    assert m.busy(Y, 2.0)
    assert m.lp(X, 2.0) == p
    assert m.lp(X, 9.0) == p
    assert m.lp(Y, 9.0) == 50_000


def test_hold_and_start() -> None:
    m = _model(0)
    m.hold(X | U)
    m.fixed_move(U, 5000, 0.0)
    m.axis_assign(X, Y, 0)
    m.line((1000, 2000), 0.0)
    assert m.busy(U, 1.0) and m.busy(X | Y, 1.0)
    assert m.idle_at(U, 1.0) is None
    assert m.lp(U, 5.0) == 0
    m.start(X | U, 5.0)
    end = m.idle_at(15, 5.0)
    assert end is not None and end > 5.0
    assert (m.lp(U, end), m.lp(X, end), m.lp(Y, end)) == (5000, 1000, 2000)


def test_queued_move_follows() -> None:
    m = _model(0)
    m.fixed_move(X, 10_000, 0.0)
    first = m.idle_at(X, 0.0)
    m.abs_move(X, 0, 0.5)
    end = m.idle_at(X, 0.5)
    assert first is not None and end is not None and end > first
    assert m.next_event(0.5) == pytest.approx(first)
    assert m.lp(X, first) == 10_000
    assert m.lp(X, end) == 0


def test_set_lp_and_ep() -> None:
    m = _model(0)
    m.set_ep(X, 100, 0.0)
    m.fixed_move(X, 1000, 0.0)
    end = m.idle_at(X, 0.0)
    assert end is not None
    assert (m.lp(X, end), m.ep(X, end)) == (1000, 1100)
    m.set_lp(X, 0, end)
    assert (m.lp(X, end), m.ep(X, end)) == (0, 1100)


@settings(max_examples=80, deadline=None)
@given(dx=st.integers(-50_000, 50_000), dy=st.integers(-50_000, 50_000),
       mode=st.sampled_from([0, 1, 2, 3, 4]), absolute=st.booleans())
def test_line_2d(dx: int, dy: int, mode: int, absolute: bool) -> None:
    m = _model(0)
    m.axis_assign(Z, U, 0)
    m.set_vector_mode(mode)
    m.set_vsv(500)
    m.set_vv(8000)
    m.set_va(60_000)
    m.set_vd(30_000)
    m.set_vk(1_000_000)
    m.set_vl(500_000)
    m.set_lp(Z, 7, 0.0)
    m.set_lp(U, -3, 0.0)
    m.line((dx, dy), 0.0, absolute=absolute)
    tx, ty = (dx, dy) if absolute else (7 + dx, -3 + dy)
    end = m.idle_at(Z | U, 0.0)
    assert end is not None
    length = math.hypot(tx - 7, ty + 3)
    for t in _samples(0.0, end, 40):
        x, y = m.lp(Z, t) - 7, m.lp(U, t) + 3
        if length:
            assert abs(x * (ty + 3) - y * (tx - 7)) / length <= 1.0
        assert math.hypot(m.cv(Z, t), m.cv(U, t)) <= 8000 + 1e-6
        assert m.busy(Z, t) == (t < end)
    assert (m.lp(Z, end), m.lp(U, end)) == (tx, ty)


def test_line_3d() -> None:
    m = _model(0)
    m.axis_assign(X, Y, Z)
    m.set_vector_mode(8)
    m.line((10_000, 1000, 20_000), 0.0)
    end = m.idle_at(X | Y | Z, 0.0)
    assert end is not None
    assert [m.lp(a, end) for a in (X, Y, Z)] == [10_000, 1000, 20_000]


@pytest.mark.parametrize("clockwise", [True, False])
def test_arc_direction_radius_and_end(clockwise: bool) -> None:
    m = _model(0)
    m.axis_assign(X, Y, 0)
    m.set_vector_mode(5)
    m.set_vsv(100)
    m.set_vv(3000)
    m.set_va(5000)
    m.set_vao(0)  # no offset pulses: the profile is the plain symmetric T-curve
    # start (0, 0), centre (10000, 0): radius 10000; finish (10000, 10000) is the top
    m.arc((10_000, 0), (10_000, 10_000), clockwise, 0.0)
    end = m.idle_at(X | Y, 0.0)
    assert end is not None
    angles = []
    for t in _samples(0.0, end, 80):
        x, y = m.lp(X, t) - 10_000, m.lp(Y, t)
        assert abs(math.hypot(x, y) - 10_000) <= 1.0
        angles.append(math.atan2(y, x) % (2 * math.pi))
    assert (m.lp(X, end), m.lp(Y, end)) == (10_000, 10_000)
    # Axis 1 right, axis 2 up; CW = decreasing polar angle.  The start is at 180 deg
    # around the centre and the finish at 90 deg: CW is a quarter circle through 135 deg,
    # CCW three quarters through 315 deg.
    mid = angles[len(angles) // 2]
    sweep = math.pi / 2 if clockwise else 3 * math.pi / 2
    length = sweep * 10_000
    ramp = (3000**2 - 100**2) / (2 * 5000)
    assert end == pytest.approx(2 * 2900 / 5000 + (length - 2 * ramp) / 3000)
    assert mid == pytest.approx(math.radians(135 if clockwise else 315), abs=1e-3)


def test_circle_and_absolute_arc() -> None:
    m = _model(0)
    m.axis_assign(X, Y, 0)
    m.set_vv(5000)
    m.set_lp(X | Y, 100, 0.0)
    m.circle((0, 1000), False, 0.0)
    end = m.idle_at(X | Y, 0.0)
    assert end == pytest.approx(2 * math.pi * 1000 / 5000)
    quarter = end / 4
    # CCW around (100, 1100) from the bottom point: first towards +X
    assert m.lp(X, quarter) == 1100 and m.lp(Y, quarter) == 1100
    assert (m.lp(X, end), m.lp(Y, end)) == (100, 100)
    m.arc((0, 0), (-100, 100), True, end, absolute=True)
    end2 = m.idle_at(3, end)
    assert end2 is not None
    assert (m.lp(X, end2), m.lp(Y, end2)) == (-100, 100)


def test_vector_stop() -> None:
    m = _model(0)
    m.axis_assign(X, Y, 0)
    m.set_vector_mode(1)
    m.set_vsv(1000)
    m.set_vv(10_000)
    m.set_va(100_000)
    m.line((30_000, 40_000), 0.0)
    m.vector_stop(2.0, sudden=False)
    end = m.idle_at(3, 2.0)
    assert end == pytest.approx(2.09)
    x, y = m.lp(X, end), m.lp(Y, end)
    assert abs(x * 4 - y * 3) <= 5
    assert math.hypot(x, y) == pytest.approx(495 + 1.91 * 10_000 + 495, abs=1.5)
    m.line((10, 10), end)
    m.vector_stop(end, sudden=True)
    assert not m.busy(3, end)


@settings(max_examples=40, deadline=None)
@given(moves=st.lists(st.tuples(st.sampled_from([X, Y, Z, U]), st.integers(-5000, 5000),
                                st.floats(0.0, 0.5)), min_size=1, max_size=6))
def test_idle_at_and_next_event_agree_with_busy(moves: list[tuple[int, int, float]]) -> None:
    m = _model(1)
    now = 0.0
    for axis, dist, gap in moves:
        m.fixed_move(axis, dist, now)
        now += gap
    idle = m.idle_at(15, now)
    assert idle is not None and idle >= now
    # queries must not go back in time: walk the events forwards
    t = now
    while True:
        nxt = m.next_event(t)
        if nxt is None:
            break
        assert nxt > t
        assert m.busy(15, (t + nxt) / 2)
        assert m.idle_at(15, (t + nxt) / 2) == pytest.approx(idle)
        t = nxt
    assert t == pytest.approx(idle)
    assert not m.busy(15, idle)


# ------------------------------------------- motions ending together (`_finish_ended`)
@settings(max_examples=60, deadline=None)
@given(moves=st.lists(st.tuples(st.sampled_from([X, Y, Z, U, X | Y]),
                                st.integers(-30_000, 30_000)), min_size=1, max_size=6),
       shift=st.one_of(st.none(), st.tuples(st.sampled_from([X, Y, Z, U]),
                                           st.integers(-500, 500))),
       limits=st.booleans(), late=st.floats(0.0, 2.0))
def test_motions_settled_at_once_end_as_one_by_one(
        moves: list[tuple[int, int]], shift: tuple[int, int] | None, limits: bool,
        late: float) -> None:
    """Settling long after several moves ended (one `_recompute` for all of them where no
    I/O event, interrupt or queued command can come between) leaves the model as settling
    at each end in turn: positions, EP, reports, the next event and the I/O's time."""
    def started() -> MotionModel:
        m = _model(0)
        if limits:  # X's software limits: I/O events, the ends are settled one by one
            m.io.set_slmt(X, 8_000, -8_000, 0, 0.0)
        for mask, pulses in moves:
            if mask == X | Y:
                m.line((pulses, pulses // 2), 0.0)
            else:
                m.fixed_move(mask, pulses, 0.0)
        if shift is not None:
            m.set_lp(shift[0], shift[1], 0.01)
        return m

    at_once, one_by_one = started(), started()
    ends = sorted({ax.motion.end for ax in one_by_one._ax if ax.motion is not None})
    if not ends or ends[-1] == math.inf:
        return
    now = ends[-1] + late
    for t in ends:
        one_by_one.settle(t)
    for model in (at_once, one_by_one):
        model.settle(now)
    for model in (at_once, one_by_one):
        assert model.io.now == now
    assert [at_once.ep(1 << i, now) for i in range(4)] == \
        [one_by_one.ep(1 << i, now) for i in range(4)]
    assert [at_once.axis_report(i, now) for i in range(4)] == \
        [one_by_one.axis_report(i, now) for i in range(4)]
    assert at_once.next_event(now) == one_by_one.next_event(now)
    assert at_once.idle_at(15, now) == one_by_one.idle_at(15, now)


def test_moves_ended_long_ago_are_settled_together(monkeypatch: pytest.MonkeyPatch) -> None:
    """Four moves of different lengths: one pass of `settle` ends the first, the next ends
    the three others together."""
    passes: list[float] = []
    end_due = MotionModel._end_due

    def counted(self: MotionModel, t: float) -> None:
        passes.append(t)
        end_due(self, t)

    monkeypatch.setattr(MotionModel, "_end_due", counted)
    m = _model(0)
    for mask, pulses in ((X, 5_000), (Y, -3_000), (Z, 1_000), (U, 700)):
        m.fixed_move(mask, pulses, 0.0)
    first = m.next_event(0.0)
    m.settle(10.0)
    assert passes == [first, 10.0]
    assert [m.lp(1 << i, 10.0) for i in range(4)] == [5_000, -3_000, 1_000, 700]


# ------------------------------------- a queued command built once (`_Cmd.built`)
@pytest.mark.parametrize("shift", [0, 250])
def test_a_queued_arc_starts_as_running_ahead_built_it(shift: int) -> None:
    """`idle_at` runs ahead over the line and builds the arc queued behind it; when the line
    ends, the arc starts as built there, unless SET_LP moved an axis since (it is built
    again from the new position). Either way it runs as on a model that never ran ahead."""
    def queued() -> MotionModel:
        m = _model(0)
        m.axis_assign(X, Y, 0)
        m.line((4_000, 3_000), 0.0)
        m.arc((1_000, 0), (2_000, 0), True, 0.0)
        return m

    ahead, plain = queued(), queued()
    end = ahead.idle_at(X | Y, 0.0)
    assert end is not None
    built = ahead._queue[0].built
    assert built is not None
    if shift:
        for m in (ahead, plain):
            m.set_lp(X, m.lp(X, 0.05) + shift, 0.05)
    line_end = plain.next_event(0.05)
    assert line_end is not None
    for m in (ahead, plain):
        m.settle(line_end)
    started = ahead._ax[0].motion
    assert started is not None and (started is built[2]) == (shift == 0)
    for t in _samples(line_end, end + 0.1):
        assert [ahead.lp(a, t) for a in (X, Y)] == [plain.lp(a, t) for a in (X, Y)]
    assert ahead.idle_at(X | Y, end) == plain.idle_at(X | Y, end)
