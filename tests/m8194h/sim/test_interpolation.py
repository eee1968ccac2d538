"""Continuous interpolation, the rounded rectangle and the helix (manual 7.4, 7.5.9), and
the end positions of the manual's chapter 7 interpolation examples.

Expectations come from the statements (and the conventions of `mplang.m8194h.sim.motion`), not
from the prose: the 3-axis continuous examples say "end ... interpolation" but send their
last segment with nType 0 (RS 8601, 8680), so they end by running out of segments.
"""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import Options, compile_source
from mplang.m8194h.run import run_build
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.motion import MotionModel

X, Y, Z, U = 1, 2, 4, 8
LINE_TIME = 1e-4  # device profile [execution] line_time_us


def run(source: str) -> VirtualController:
    build = compile_source(source, options=Options(target="rs"))  # INTP_END is RS only
    assert build.ok, [d.render() for d in build.diagnostics]
    report = run_build(build)
    assert report.result.finished, report.result.error
    return report.controller


def positions(vc: VirtualController) -> list[int]:
    return [vc.motion.lp(a, vc.clock) for a in (X, Y, Z, U)]


def t_curve_time(length: float, sv: float, v: float, acc: float, dec: float) -> float:
    """Duration of one T-curve over `length` from and to `sv` (independent formula)."""
    ramps = (v * v - sv * sv) / (2 * acc) + (v * v - sv * sv) / (2 * dec)
    if ramps <= length:
        return (v - sv) / acc + (v - sv) / dec + (length - ramps) / v
    peak = math.sqrt(sv * sv + 2 * length * acc * dec / (acc + dec))
    return (peak - sv) / acc + (peak - sv) / dec


def model() -> MotionModel:
    m = MotionModel()
    m.set_max_v(15, 160_000)  # speed resolution 20 PPS: the speeds below are exact
    return m


def vector_speed(m: MotionModel, axes: tuple[int, ...], t: float) -> float:
    return math.hypot(*(m.cv(a, t) for a in axes))


def samples(t0: float, t1: float, n: int = 50) -> list[float]:
    return [t0 + (t1 - t0) * i / n for i in range(n + 1)]


def seg_distance(p: tuple[float, float], a: tuple[int, int], b: tuple[int, int]) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    den = dx * dx + dy * dy
    f = 0.0 if den == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / den))
    return math.hypot(p[0] - a[0] - f * dx, p[1] - a[1] - f * dy)


# ------------------------------------------------------------- continuous lines


@settings(max_examples=40, deadline=None)
@given(segs=st.lists(st.tuples(st.integers(-3000, 3000), st.integers(-3000, 3000)),
                     min_size=1, max_size=7),
       absolute=st.booleans(), gap=st.sampled_from([0.0, LINE_TIME]))
def test_continuous_lines_run_as_one_profile(segs: list[tuple[int, int]], absolute: bool,
                                             gap: float) -> None:
    """Segments join without slowing down: the chain takes exactly the time of one T-curve
    over the total length, stays on the polyline and ends exactly on the last point."""
    m = model()
    m.set_lp(X, 50, 0.0)
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    points = [(50, 0)]
    t = 0.0
    for k, (dx, dy) in enumerate(segs):
        points.append((points[-1][0] + dx, points[-1][1] + dy))
        m.continuous_line(points[-1] if absolute else (dx, dy), k == len(segs) - 1, t,
                          absolute=absolute)
        t += gap
    length = sum(math.dist(a, b) for a, b in itertools.pairwise(points))
    first = next((i for i in range(len(segs)) if segs[i] != (0, 0)), None)
    end = m.idle_at(X | Y, t)
    assert end is not None
    if first is not None:
        assert end == pytest.approx(first * gap + t_curve_time(length, 300, 18_000, 500_000,
                                                               500_000), abs=1e-9)
    for s in samples(t, end, 40):
        p = (m.lp(X, s), m.lp(Y, s))
        assert min(seg_distance(p, a, b) for a, b in itertools.pairwise(points)) <= 1
        assert vector_speed(m, (X, Y), s) <= 18_000 + 1e-6
    assert (m.lp(X, end), m.lp(Y, end)) == points[-1]
    assert not m.busy(X | Y, end)


def test_manual_7_4_3_parameters_hold_the_vector_speed_across_segments() -> None:
    """The 7.4.3 example's 141-pulse zig-zag, segments arriving one per macro line while
    the chain runs: after the first 324 pulses of ramp the vector speed stays at VV until
    the final deceleration, which brings it to VSV at the last point."""
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    n = 41
    for k in range(n):
        d = 100 if k % 2 == 0 else -100
        m.continuous_line((d, d), k == n - 1, k * LINE_TIME)
    t = (n - 1) * LINE_TIME
    length = n * 100 * math.sqrt(2)
    ramp = (18_000**2 - 300**2) / (2 * 500_000)
    end = m.idle_at(X | Y, t)
    assert end == pytest.approx(t_curve_time(length, 300, 18_000, 500_000, 500_000))
    assert end is not None and end - 2 * 17_700 / 500_000 > (length - 2 * ramp) / 18_000 - 1e-9
    cruise = (17_700 / 500_000, end - 17_700 / 500_000)
    for s in samples(max(t, cruise[0] + 1e-6), cruise[1] - 1e-6, 200):
        assert vector_speed(m, (X, Y), s) == pytest.approx(18_000)
    assert vector_speed(m, (X, Y), end - 1e-6) == pytest.approx(300, abs=1)
    assert (m.lp(X, end), m.lp(Y, end)) == (100, 100)


def test_a_chain_that_runs_out_of_segments_stops_without_decelerating() -> None:
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    m.continuous_line((30_000, 0), False, 0.0)
    end = m.idle_at(X | Y, 0.0)
    ramp = (18_000**2 - 300**2) / 1_000_000
    assert end == pytest.approx(17_700 / 500_000 + (30_000 - ramp) / 18_000)
    assert m.cv(X, end - 1e-6) == pytest.approx(18_000)
    assert m.lp(X, end) == 30_000
    # a segment after the stop starts a new chain from rest, at VSV
    m.continuous_line((0, 5000), True, end + 1.0)
    assert m.cv(Y, end + 1.0) == pytest.approx(300)
    end2 = m.idle_at(X | Y, end + 1.0)
    assert end2 == pytest.approx(end + 1.0 + t_curve_time(5000, 300, 18_000, 500_000, 500_000))
    assert (m.lp(X, end2), m.lp(Y, end2)) == (30_000, 5000)


@pytest.mark.parametrize(("dims", "closes"), [(2, True), (3, False)])
def test_intp_end_closes_the_open_chain_of_its_type(dims: int, closes: bool) -> None:
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    m.continuous_line((30_000, 0), False, 0.0)
    m.continuous_line((0, 10_000), False, 0.01)
    m.intp_end(dims, 0.02)
    end = m.idle_at(X | Y, 0.02)
    assert end is not None
    speed_at_end = vector_speed(m, (X, Y), end - 1e-6)
    if closes:
        assert end == pytest.approx(t_curve_time(40_000, 300, 18_000, 500_000, 500_000))
        assert speed_at_end == pytest.approx(300, abs=1)
    else:
        assert speed_at_end == pytest.approx(18_000)
    assert (m.lp(X, end), m.lp(Y, end)) == (30_000, 10_000)


def test_a_late_last_segment_brakes_at_once_and_still_ends_exactly() -> None:
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    m.continuous_line((2000, 0), False, 0.0)
    t_open = m.idle_at(X | Y, 0.0)
    assert t_open is not None
    late = t_open - 0.005  # 90 pulses before the end: less than the 324 the ramp needs
    m.continuous_line((100, 0), True, late)
    assert m.ca(X, late + 1e-4) == pytest.approx(-500_000)
    end = m.idle_at(X, late)
    assert end is not None
    assert 300 < m.cv(X, end - 1e-6) < 18_000
    assert m.lp(X, end) == 2100


def test_chain_waits_for_a_busy_axis_and_takes_all_its_segments() -> None:
    m = model()
    m.set_v(X, 10_000)
    m.fixed_move(X, 5000, 0.0)
    busy_until = m.idle_at(X, 0.0)
    assert busy_until is not None
    m.continuous_initial((X, Y), 0, 300, 18_000, 500_000)  # VECTOR_SPEED 0: constant VV
    for k, d in enumerate([(1000, 0), (0, 1000), (-1000, 0)]):
        m.continuous_line(d, k == 2, 0.0)
    end = m.idle_at(X | Y, 0.0)
    assert m.lp(Y, busy_until - 1e-3) == 0
    assert end == pytest.approx(busy_until + 3000 / 18_000)
    assert m.cv(Y, busy_until + (1500 / 18_000)) == pytest.approx(18_000)
    assert (m.lp(X, end), m.lp(Y, end)) == (5000, 1000)


def test_a_held_chain_collects_its_segments_until_drv_start() -> None:
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    m.hold(X)
    for k in range(5):
        m.continuous_line((1000, 500), k == 4, k * LINE_TIME)
    assert m.busy(X | Y, 1.0) and m.lp(X, 1.0) == 0
    m.start(X, 1.0)
    end = m.idle_at(X | Y, 1.0)
    assert end == pytest.approx(1.0 + t_curve_time(5 * math.hypot(1000, 500), 300, 18_000,
                                                   500_000, 500_000))
    assert (m.lp(X, end), m.lp(Y, end)) == (5000, 2500)


def test_a_stopped_chain_takes_no_more_segments() -> None:
    m = model()
    m.continuous_initial((X, Y), 1, 300, 18_000, 500_000)
    m.continuous_line((50_000, 0), False, 0.0)
    m.vector_stop(0.5, sudden=True)
    stopped = m.lp(X, 0.5)
    assert 0 < stopped < 50_000 and not m.busy(X | Y, 0.5)
    m.continuous_line((0, 1000), True, 0.6)  # a new chain, from where the axes stand
    end = m.idle_at(X | Y, 0.6)
    assert end is not None
    assert (m.lp(X, end), m.lp(Y, end)) == (stopped, 1000)


def test_continuous_3d_lines_and_set_lp_during_an_absolute_chain() -> None:
    m = model()
    m.continuous_initial((Y, Z, U), 8, 300, 18_000, 500_000)  # as LINE_3D_INITIAL
    assert m.assigned == (1, 2, 3)
    assert (m.vector.mode, m.vector.vsv, m.vector.vv, m.vector.va) == (8, 300, 18_000, 500_000)
    m.continuous_line((1000, 2000, 3000), False, 0.0, absolute=True)
    assert m.lp(Y, 0.01) < 1000
    m.set_lp(Y, 10_000, 0.01)  # Y's counter jumps ahead of the path it is on
    m.continuous_line((20_000, 4000, 0), True, 0.01, absolute=True)
    end = m.idle_at(Y | Z | U, 0.01)
    assert end is not None
    assert [m.lp(a, end) for a in (Y, Z, U)] == [20_000, 4000, 0]


# ------------------------------------------------------------------ mixed 2-axis


@pytest.mark.parametrize("absolute", [False, True])
def test_mix_2d_lines_arcs_and_circle_at_constant_speed(absolute: bool) -> None:
    m = model()
    m.continuous_initial((X, Y), 0, 300, 5000, 500_000)  # MIX_2D_INITIAL nAcc 0
    # line to (1000, 0); CCW quarter around (1000, 1000) to (2000, 1000); CW circle
    # around (1000, 1000); line to (2000, 2000), the last segment
    if absolute:
        m.continuous_mix(1, (0, 0), (1000, 0), False, 0.0, absolute=True)
        m.continuous_mix(3, (1000, 1000), (2000, 1000), False, 0.0, absolute=True)
        m.continuous_mix(4, (1000, 1000), (0, 0), False, 0.0, absolute=True)
        m.continuous_mix(1, (0, 0), (2000, 2000), True, 0.0, absolute=True)
    else:
        m.continuous_mix(1, (0, 0), (1000, 0), False, 0.0)
        m.continuous_mix(3, (0, 1000), (1000, 1000), False, 0.0)
        m.continuous_mix(4, (-1000, 0), (0, 0), False, 0.0)
        m.continuous_mix(1, (0, 0), (0, 1000), True, 0.0)
    quarter, circle = 500 * math.pi, 2000 * math.pi
    end = m.idle_at(X | Y, 0.0)
    assert end == pytest.approx((2000 + quarter + circle) / 5000)
    for s in samples(0.0, end - 1e-9, 60):
        assert vector_speed(m, (X, Y), s) == pytest.approx(5000)

    def at(length: float) -> tuple[int, int]:
        t = length / 5000
        return m.lp(X, t), m.lp(Y, t)

    r = 1000 / math.sqrt(2)
    assert at(1000 + quarter / 2) == (round(1000 + r), round(1000 - r))  # CCW: below
    assert at(1000 + quarter + circle / 4) == (1000, 0)  # CW from the right: down
    assert at(1000 + quarter + circle * 3 / 4) == (1000, 2000)
    assert (m.lp(X, end), m.lp(Y, end)) == (2000, 2000)


# --------------------------------------------------------------------- rectangle

def tangent_point(sp: int, lp: int, wp: int, r: int) -> tuple[int, int]:
    """Sp0-Sp7 as motion.py defines them: counter-clockwise from the left end of the lower
    side, in the frame of the bounding box (axis 1 along Lp, axis 2 along Wp)."""
    return ((r, 0), (lp - r, 0), (lp, r), (lp, wp - r), (lp - r, wp), (r, wp), (0, wp - r),
            (0, r))[sp % 8]


@settings(max_examples=40, deadline=None)
@given(sp=st.integers(0, 7), clockwise=st.booleans(), constant=st.booleans(),
       lp=st.integers(1, 30_000), wp=st.integers(1, 30_000), rp=st.integers(0, 20_000))
def test_rectangle_lap(sp: int, clockwise: bool, constant: bool, lp: int, wp: int,
                       rp: int) -> None:
    m = model()
    m.set_lp(Z, 123, 0.0)
    m.set_lp(U, -77, 0.0)
    m.rectangle((Z, U), constant, sp, clockwise, (lp, wp, rp), (1000, 10_000, 50_000, 20_000),
                0.0)
    r = min(rp, lp // 2, wp // 2)
    tx, ty = tangent_point(sp, lp, wp, r)
    ox, oy = 123 - tx, -77 - ty  # the bounding box's lower-left corner
    perimeter = 2 * (lp - 2 * r) + 2 * (wp - 2 * r) + 2 * math.pi * r
    end = m.idle_at(Z | U, 0.0)
    assert end is not None
    # the first pulse heads for the next distinct tangent point in the travel direction
    step = -1 if clockwise else 1
    here = tangent_point(sp, lp, wp, r)
    there = next(q for q in (tangent_point(sp + step * k, lp, wp, r) for k in range(1, 9))
                 if q != here)
    t = 0.0
    while (m.lp(Z, t), m.lp(U, t)) == (123, -77):
        t += 2e-5  # at most 0.2 pulse per step
    move = (m.lp(Z, t) - 123, m.lp(U, t) + 77)
    assert move[0] * (there[0] - here[0]) + move[1] * (there[1] - here[1]) > 0
    if constant:
        assert end == pytest.approx(perimeter / 10_000)
    else:
        assert end == pytest.approx(t_curve_time(perimeter, 1000, 10_000, 50_000, 20_000))
    pts = []
    for s in samples(0.0, end, 80):
        x, y = m.lp(Z, s) - ox, m.lp(U, s) - oy
        pts.append((x, y))
        # distance to the rounded rectangle = |distance to the inner box - r|
        inner = math.hypot(max(r - x, 0, x - (lp - r)), max(r - y, 0, y - (wp - r)))
        on_edge = min(x, lp - x, y, wp - y) if inner == 0 else abs(inner - r)
        assert on_edge <= 1.0
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    assert min(xs) >= 0 and max(xs) <= lp and min(ys) >= 0 and max(ys) <= wp
    area = sum(a[0] * b[1] - b[0] * a[1] for a, b in itertools.pairwise(pts))
    if lp > 4 and wp > 4:
        assert (area < 0) == clockwise
    assert (m.lp(Z, end), m.lp(U, end)) == (123, -77)


def test_rectangle_manual_example_passes_its_corners() -> None:
    """RS 8228: 20000 x 10000, radius 1000, Sp0 CCW, T-curve 1000 -> 10000 at 5000."""
    m = model()
    m.rectangle((X, Y), False, 0, False, (20_000, 10_000, 1000), (1000, 10_000, 5000, 5000),
                0.0)
    perimeter = 2 * 18_000 + 2 * 8000 + 2000 * math.pi
    end = m.idle_at(X | Y, 0.0)
    assert end == pytest.approx(t_curve_time(perimeter, 1000, 10_000, 5000, 5000))
    cruise_from = 9000 / 5000
    ramp = (10_000**2 - 1000**2) / 10_000

    def at(length: float) -> tuple[int, int]:
        return m.lp(X, cruise_from + (length - ramp) / 10_000), m.lp(Y, cruise_from + (
            length - ramp) / 10_000)

    # the start (0, 0) is Sp0 = (Rp, 0) of the box, so the box spans x -1000..19000
    quarter = 500 * math.pi
    assert at(18_000) == (18_000, 0)  # Sp1, end of the lower side
    r = 1000 / math.sqrt(2)
    assert at(18_000 + quarter / 2) == (round(18_000 + r), round(1000 - r))
    assert at(18_000 + quarter + 8000) == (19_000, 9000)  # Sp3
    assert at(2 * 18_000 + 2 * quarter + 8000) == (0, 10_000)  # Sp5, end of the top
    assert (m.lp(X, end), m.lp(Y, end)) == (0, 0)


# ------------------------------------------------------------------------- helix


@settings(max_examples=40, deadline=None)
@given(cycle=st.integers(-3, 3), pitch=st.integers(-5000, 5000),
       cx=st.integers(-3000, 3000), cy=st.integers(-3000, 3000), clockwise=st.booleans())
def test_helix_turns_and_pitch(cycle: int, pitch: int, cx: int, cy: int,
                               clockwise: bool) -> None:
    m = model()
    m.set_lp(X, 40, 0.0)
    m.set_lp(U, 500, 0.0)
    m.helix((Y, X, U), clockwise, 20_000, (cx, cy), cycle, pitch, 0.0)
    radius = math.hypot(cx, cy)  # axis 1 is Y, axis 2 is X: the start is (0, 40)
    turns = abs(cycle) if radius else 0
    dz = cycle * pitch
    length = math.hypot(2 * math.pi * radius * turns, dz)
    end = m.idle_at(X | Y | U, 0.0)
    assert end is not None
    if length == 0:
        assert end == 0.0
        return
    assert end == pytest.approx(length / 20_000)
    swept = 0.0
    prev = math.atan2(-cy, -cx)
    for s in samples(0.0, end, 24 * max(turns, 1)):
        a1, a2 = m.lp(Y, s) - cx, m.lp(X, s) - 40 - cy
        if radius:
            assert abs(math.hypot(a1, a2) - radius) <= 1.0
            ang = math.atan2(a2, a1)
            swept += (ang - prev + math.pi) % (2 * math.pi) - math.pi
            prev = ang
            if radius > 50:  # angle known to 1/radius: z to pitch/(2 pi radius)
                tol = 1.0 + abs(pitch) / (2 * math.pi * radius) * 1.5
                assert m.lp(U, s) - 500 == pytest.approx(dz * abs(swept) / (2 * math.pi *
                                                                            turns), abs=tol)
        if s < end:
            assert vector_speed(m, (X, Y, U), s) == pytest.approx(20_000)
    if radius > 50:
        assert swept == pytest.approx((-1 if clockwise else 1) * 2 * math.pi * turns, abs=0.1)
    assert (m.lp(Y, end), m.lp(X, end), m.lp(U, end)) == (0, 40, 500 + dz)


def test_helix_runs_at_the_vector_speed_in_three_dimensions() -> None:
    m = model()
    m.helix((X, Y, Z), False, 10_000, (1000, 0), 2, 3000, 0.0)
    end = m.idle_at(7, 0.0)
    assert end is not None
    for s in samples(0.0, end - 1e-9, 30):
        assert vector_speed(m, (X, Y, Z), s) == pytest.approx(10_000)
        assert m.cv(Z, s) == pytest.approx(10_000 * 6000 / math.hypot(4000 * math.pi, 6000))


# ------------------------------------------- the manual's chapter 7 examples, run


CHAPTER_7 = [
    pytest.param("""
  SET_MAX_V XYZU, 20000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 0
  SET_VV 1000
  LINE_2D 12000, 10000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 1
  SET_VSV 500
  SET_VV 2000
  SET_VA 1000
  LINE_2D 20000, 10000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 2
  SET_VSV 200
  SET_VV 2000
  SET_VK 500
  SET_VAO 20
  LINE_2D 10000, 10000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 3
  SET_VSV 100
  SET_VV 2000
  SET_VA 1000
  SET_VD 500
  SET_VAO 20
  LINE_2D 10000, 5000
  SET_MAX_V XYZU, 8000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 4
  SET_VSV 200
  SET_VV 2000
  SET_VK 500
  SET_VL 300
  SET_VAO 20
  LINE_2D 4000, 10000
  SET_MAX_V XYZU, 8000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 5
  SET_VSV 100
  SET_VV 3000
  SET_VA 5000
  SET_VAO 0
  ARC_CW 10000, 0, 11000, 9000
  SET_MAX_V XYZU, 8000
  AXIS_ASSIGN X, Y, 0
  VECTOR_SPEED 6
  SET_VSV 100
  SET_VV 3000
  SET_VA 125
  SET_VD 12
  SET_VAO 0
  CIRCLE_CW 300, 0
  AXIS_ASSIGN X, Y, Z
  VECTOR_SPEED 7
  SET_VSV 1000
  SET_VV 1000
  LINE_3D 10000, 10000, 10000
  AXIS_ASSIGN X, Y, Z
  VECTOR_SPEED 8
  SET_VSV 100
  SET_VV 3000
  SET_VA 500
  SET_VAO 20
  LINE_3D 10000, 1000, 20000
  AXIS_ASSIGN X, Y, Z
  VECTOR_SPEED 9
  SET_VSV 100
  SET_VV 3000
  SET_VK 500
  SET_VAO 20
  LINE_3D 10000, 1000, 1000
  AXIS_ASSIGN X, Y, Z
  VECTOR_SPEED 10
  SET_VSV 100
  SET_VV 2000
  SET_VA 1000
  SET_VD 500
  SET_VAO 20
  LINE_3D 10000, 1000, 1000
  SET_MAX_V XYZU, 8000
  AXIS_ASSIGN X, Y, Z
  VECTOR_SPEED 11
  SET_VSV 200
  SET_VV 2000
  SET_VK 500
  SET_VL 300
  SET_VAO 20
  LINE_3D 4000, 10000, 20000
""", [111_000, 77_000, 52_000, 0], id="7.2.2-related-RS5789"),
    pytest.param("LINE_2D 12000, 10000", [12_000, 10_000, 0, 0], id="7.2.10-RS6444"),
    pytest.param("ABS_LINE_2D 12000, 10000", [12_000, 10_000, 0, 0], id="7.2.11-RS6498"),
    pytest.param("AXIS_ASSIGN X, Y, Z\n LINE_3D 10000, 10000, 10000",
                 [10_000, 10_000, 10_000, 0], id="7.2.12-RS6553"),
    pytest.param("AXIS_ASSIGN X, Y, Z\n ABS_LINE_3D 10000, 10000, 10000",
                 [10_000, 10_000, 10_000, 0], id="7.2.13-RS6612"),
    pytest.param("ARC_CW -5000, -5000, -10000, -10000", [-10_000, -10_000, 0, 0],
                 id="7.2.14-RS6668"),
    pytest.param("ARC_CCW -5000, -5000, -10000, -10000", [-10_000, -10_000, 0, 0],
                 id="7.2.15-RS6729"),
    pytest.param("ABS_ARC_CW -5000, -5000, -10000, -10000", [-10_000, -10_000, 0, 0],
                 id="7.2.16-RS6792"),
    pytest.param("ABS_ARC_CCW -5000, -5000, -10000, -10000", [-10_000, -10_000, 0, 0],
                 id="7.2.17-RS6855"),
    pytest.param("CIRCLE_CW 0, 10000", [0, 0, 0, 0], id="7.2.18-RS6915"),
    pytest.param("CIRCLE_CCW 0, 10000", [0, 0, 0, 0], id="7.2.19-RS6967"),
    pytest.param("RECTANGLE X, Y, 1, 0, 0, 20000, 10000, 1000, 1000, 10000, 5000, 5000",
                 [0, 0, 0, 0], id="7.4.1-RS8228"),
    pytest.param("""
  SET_MAX_V XYZU, 160000
  LINE_2D_INITIAL X, Y, 300, 18000, 500000
  FOR 100
    ABS_LINE_2D_CONTINUE 0, 100, 100
    ABS_LINE_2D_CONTINUE 0, -100, -100
  NEXT
  ABS_LINE_2D_CONTINUE 1, 100, 100
""", [100, 100, 0, 0], id="7.4.4-related-RS8455-100-loops"),
    pytest.param("""
  SET_MAX_V XYZU, 160000
  LINE_3D_INITIAL X, Y, Z, 300, 18000, 500000
  FOR 100
    LINE_3D_CONTINUE 0, 100, 100, 100
    LINE_3D_CONTINUE 0, -100, -100, -100
  NEXT
  LINE_3D_CONTINUE 0, 100, 100, 100
""", [100, 100, 100, 0], id="7.4.6-related-RS8594-100-loops"),
    pytest.param("""
  MIX_2D_INITIAL X, Y, 0, 300, 18000, 500000
  MIX_2D_CONTINUE 0, 1, 0, 0, 100, 100
""", [100, 100, 0, 0], id="7.4.8-7.4.9-RS8722-8780"),
    pytest.param("""
  MIX_2D_INITIAL X, Y, 0, 300, 18000, 500000
  ABS_MIX_2D_CONTINUE 0, 1, 0, 0, 100, 100
""", [100, 100, 0, 0], id="7.4.8-7.4.10-RS8722-8837"),
    pytest.param("HELIX_3D Y, Z, U, 1, 50000, 0, 25000, 50, 3600", [0, 0, 0, 180_000],
                 id="7.4.11-RS8898"),
    pytest.param("""
  SET_MAX_V XYZU, 160000
  HELIX_3D Y, Z, X, 1, 50000, 0, 1000, 5, -2000
  SET_MAX_V XYZU, 160000
  HELIX_3D Y, Z, U, 1, 100000, 0, 25000, 50, 3600
""", [-10_000, 0, 0, 180_000], id="7.4.11-related-RS8907"),
    pytest.param("""
  LINE_2D_INITIAL X, Y, 300, 18000, 500000
  LINE_2D_CONTINUE 0, 3000, 4000
  INTP_END 0
""", [3000, 4000, 0, 0], id="7.5.9-RS9577"),
]


@pytest.mark.parametrize(("body", "expected"), CHAPTER_7)
def test_manual_chapter_7_examples_end_where_their_statements_say(
        body: str, expected: list[int]) -> None:
    vc = run(f"MP 156\n{body}\nEND MP\n")
    assert positions(vc) == expected
    assert not vc.motion.busy(15, vc.clock)


def test_manual_7_4_3_example_as_printed_never_stops_between_segments() -> None:
    """RS 8380-8387, 10000 loops: 20001 segments of 100*sqrt(2) pulses in one T-curve."""
    vc = run("""MP 156
  SET_MAX_V XYZU, 160000
  LINE_2D_INITIAL X, Y, 300, 18000, 500000
  FOR 10000
    LINE_2D_CONTINUE 0, 100, 100
    LINE_2D_CONTINUE 0, -100, -100
  NEXT
  LINE_2D_CONTINUE 1, 100, 100
END MP
""")
    assert positions(vc) == [100, 100, 0, 0]
    start = 4 * LINE_TIME  # the first segment is the fourth line
    length = 20_001 * 100 * math.sqrt(2)
    assert vc.clock == pytest.approx(start + t_curve_time(length, 300, 18_000, 500_000,
                                                          500_000))


def test_manual_7_4_7_example_runs_out_at_full_speed() -> None:
    """RS 8672-8680 (1000 loops instead of 10000, which changes only the time): the closing
    call is a relative LINE_3D_CONTINUE with nType 0, so the chain ends by running out of
    segments (no deceleration) after the absolute zig-zag."""
    vc = run("""MP 156
  SET_MAX_V XYZU, 160000
  LINE_3D_INITIAL X, Y, Z, 300, 18000, 500000
  FOR 1000
    ABS_LINE_3D_CONTINUE 0, 100, 100, 100
    ABS_LINE_3D_CONTINUE 0, -100, -100, -100
  NEXT
  LINE_3D_CONTINUE 0, 100, 100, 100
END MP
""")
    assert positions(vc) == [0, 0, 0, 0]
    length = math.sqrt(3) * (100 + 1999 * 200 + 100)
    ramp = (18_000**2 - 300**2) / 1_000_000
    assert vc.clock == pytest.approx(4 * LINE_TIME + 17_700 / 500_000
                                     + (length - ramp) / 18_000)
