"""Axis I/O of the virtual M8194H: sensors, limits, home search, emergency stop, error codes,
compare, latch, synchronous actions and interrupt factors.

Expected positions and times are worked out here from the sensor layout and the profile
formulas (T-curve: SV 1000, V 10000, A 100000 reaches V after 0.09 s and 495 pulses), not
read back from the model.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import pick_program
from mplang.m8194h.sim import axis_io, signals
from mplang.m8194h.sim.axis_io import AxisSensors
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.motion import MotionModel

X, Y, Z, U = 1, 2, 4, 8
NO_SENSORS = AxisSensors(near_home=None, home=None, index_period=None)
EXAMPLES = tomllib.loads(
    (Path(__file__).resolve().parents[2] / "data" / "manual_examples.toml").read_text())["example"]


def example(command: str) -> str:
    """The mplang statement of the manual's example for a MACRO command."""
    return next(e["source"] for e in EXAMPLES if e["command"] == command)


def model(**sensors: object) -> MotionModel:
    """T-curve axes (SV 1000, V 10000, A 100000) and the given sensors on every axis."""
    m = MotionModel()
    m.set_sv(15, 1000)
    m.set_v(15, 10_000)
    m.set_a(15, 100_000)
    for i in range(4):
        m.io.set_sensors(i, AxisSensors(**sensors), 0.0)  # type: ignore[arg-type]
    return m


def run_machine(source: str, sensors: dict[int, AxisSensors] | None = None,
                max_time: float = 600.0) -> VirtualController:
    """Download, set up the machine's sensors, call the first MP and run it to its end."""
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController(word_order=build.word_order)
    for image in build.programs:
        assert vc.load_frames(image.program.kind, image.placement.slot, image.frames) is None
    for i, s in (sensors or {}).items():
        vc.motion.io.set_sensors(i, s, 0.0)
    vc.call(pick_program(build, None, None))
    result = vc.run(max_time=max_time)
    assert result.finished, result.error
    return vc


def cruise_time(position: float) -> float:
    """When a move from 0 at the test profile passes `position` while cruising at V."""
    return 0.09 + (position - 495) / 10_000


# ----------------------------------------------------------------------------- signals


@settings(max_examples=200, deadline=None)
@given(lo=st.integers(-50, 50), width=st.integers(0, 30), p=st.integers(-120, 120),
       d=st.sampled_from([1, -1]), invert=st.booleans(), periodic=st.booleans())
def test_signal_next_change_is_the_first_position_in_another_state(
        lo: int, width: int, p: int, d: int, invert: bool, periodic: bool) -> None:
    sig: signals._Intervals | signals._Periodic
    if periodic:
        sig = signals._Periodic(width + 5, lo, width % (width + 5) or 1)
    else:
        sig = signals._Intervals([(lo, lo + width)])
    if invert:
        sig = sig.complement()
    nxt = sig.next_change(p, d)
    q = p + d
    while abs(q - p) < 400 and sig.active(q) == sig.active(p):
        q += d
    assert nxt == (q if abs(q - p) < 400 else None)


def test_complement_of_half_lines_and_gaps() -> None:
    sig = signals._Intervals([(None, -10), (0, 5), (20, None)]).complement()
    assert sig.parts == [(-9, -1), (6, 19)]
    assert signals._Intervals([]).complement().parts == [(None, None)]


# ----------------------------------------------------------------------- hardware limits


def test_limit_stops_suddenly_on_the_switch_and_latches_the_error() -> None:
    m = model(limit_plus=20_000)
    m.fixed_move(X, 100_000, 0.0)
    end = m.idle_at(X, 0.0)
    assert end == pytest.approx(cruise_time(19_999.5))
    rep = m.axis_report(0, end)
    assert (rep.lp, rep.error_code, rep.stop_causes) == (20_000, axis_io.ERR_LIMIT_PLUS, 4)
    assert rep.di_status & 0b110 == 0b010  # LIMIT+ on, LIMIT- off
    assert m.io.error_state(end) == 1
    # moving back off the switch is allowed; the error stays until CLEAR_STOP
    m.fixed_move(X, -5_000, end)
    back = m.idle_at(X, end)
    assert back is not None
    assert m.lp(X, back) == 15_000
    assert m.io.error_code(X, back) == axis_io.ERR_LIMIT_PLUS
    m.io.clear_stop(X, back)
    assert m.io.error_state(back) == 0


def test_move_into_an_active_limit_does_not_start() -> None:
    m = model(limit_minus=0)  # the axis sits on LIMIT- at power on
    assert m.axis_report(0, 0.0).di_status & 0b100
    m.fixed_move(X, -1000, 0.0)
    assert not m.busy(X, 0.0)
    assert m.lp(X, 0.0) == 0
    assert m.io.error_code(X, 0.0) == axis_io.ERR_LIMIT_MINUS
    m.fixed_move(X, 1000, 0.0)  # away from it: fine
    assert m.lp(X, 10.0) == 1000


@settings(max_examples=40, deadline=None)
@given(mode=st.sampled_from([0, 1, 2, 3]), limit=st.integers(1, 60_000),
       target=st.integers(-60_000, 60_000))
def test_a_limit_stops_any_profile_exactly_on_the_switch(mode: int, limit: int,
                                                         target: int) -> None:
    m = model(limit_plus=limit, limit_minus=-limit)
    m.set_speed_mode(X, mode)
    m.set_k(X, 2_000_000)
    m.set_l(X, 1_000_000)
    m.fixed_move(X, target, 0.0)
    end = m.idle_at(X, 0.0)
    assert end is not None
    hit = abs(target) >= limit
    assert m.lp(X, end) == (math.copysign(limit, target) if hit else target)
    expected = 0 if not hit else (axis_io.ERR_LIMIT_PLUS if target > 0
                                  else axis_io.ERR_LIMIT_MINUS)
    assert m.io.error_code(X, end) == expected


def test_limit_stop_mode_1_decelerates_past_the_switch() -> None:
    m = model(limit_plus=20_000)
    m.io.set_limit_stop(X, 1, 0.0)
    m.continue_move(X, 10_000, 0.0)
    hit = cruise_time(19_999.5)
    end = m.idle_at(X, 0.0)
    assert end == pytest.approx(hit + 0.09)  # 10000 -> 1000 PPS at 100000 PPS/s
    assert abs(m.lp(X, end) - (20_000 + 495)) <= 1
    assert m.io.error_code(X, end) == axis_io.ERR_LIMIT_PLUS


def test_limit_stops_the_whole_interpolation() -> None:
    m = model(limit_plus=20_000)
    m.axis_assign(X, Y, 0)
    m.set_vector_mode(0)
    m.set_vv(5000)
    m.line((30_000, 40_000), 0.0)
    end = m.idle_at(X | Y, 0.0)
    # Y (4/5 of the path) reaches 19999.5 at path length 24999.375, X is then at 3/5 of it
    assert end == pytest.approx(24_999.375 / 5000)
    assert (m.lp(X, end), m.lp(Y, end)) == (15_000, 20_000)
    assert (m.io.error_code(X, end), m.io.error_code(Y, end)) == (0, axis_io.ERR_LIMIT_PLUS)


def test_limit_on_an_arc_stops_at_the_first_crossing() -> None:
    m = model(limit_minus=-900)
    m.axis_assign(X, Y, 0)
    m.set_vector_mode(0)
    m.set_vv(5000)
    m.circle((-1000, 0), False, 0.0)  # radius 1000 round (-1000, 0): X reaches -2000
    end = m.idle_at(X | Y, 0.0)
    assert end is not None
    # X = -1000 + 1000 cos(theta) falls below -899.5 at theta = acos(0.1005) - pi... CCW
    theta = math.acos(100.5 / 1000)  # angle from the +x direction, swept CCW from 0
    assert end == pytest.approx(theta * 1000 / 5000, rel=1e-6)
    assert m.lp(X, end) == -900
    assert m.io.error_code(X, end) == axis_io.ERR_LIMIT_MINUS


def test_misconfigured_active_level_makes_the_free_limit_active() -> None:
    m = model(limit_plus=20_000, wiring=0)  # engaged switch pulls low
    m.io.set_hlmt(X, 1, 0, 0.0)  # but the program says high active
    assert m.axis_report(0, 0.0).di_status & 0b10  # active away from the switch
    m.fixed_move(X, 1000, 0.0)
    assert not m.busy(X, 0.0)
    assert m.io.error_code(X, 0.0) == axis_io.ERR_LIMIT_PLUS


def test_manual_3_5_3_6_examples_stop_on_the_switch() -> None:
    vc = run_machine(f"""MP 156
  {example("RSM_MACRO_SET_HLMT")}
  {example("RSM_MACRO_LIMITSTOP_MODE")}
  SET_SV X, 1000
  SET_V X, 10000
  SET_A X, 100000
  FIXED_MOVE X, 100000
  STOP_WAIT X
  VAR1 = GET_ERROR_CODE(X)
  VAR2 = GET_ERROR
  VAR3 = GET_DI(X, 1)
  VAR4 = GET_DI_ALL(X)
  CLEAR_STOP X
  VAR5 = GET_ERROR_CODE(X)
  FIXED_MOVE X, -5000
  STOP_WAIT X
  VAR6 = GET_LP(X)
END MP
""", {0: AxisSensors(limit_plus=20_000, near_home=None, home=None, index_period=None)})
    assert vc.vars[1:7] == [4, 1, 1, 0b1111100010, 0, 15_000]


# ----------------------------------------------------------------------- software limits


def test_manual_3_9_1_software_limits_decelerate_at_fl_and_rl() -> None:
    vc = run_machine(f"""MP 156
  SET_SV XY, 1000
  SET_V XY, 10000
  SET_A XY, 100000
  {example("RSM_MACRO_SET_SLMT")}
  FIXED_MOVE X, 100000
  FIXED_MOVE Y, -100000
  STOP_WAIT X
  STOP_WAIT Y
  VAR1 = GET_LP(X)
  VAR2 = GET_LP(Y)
  VAR3 = GET_ERROR_CODE(X)
  VAR4 = GET_ERROR_CODE(Y)
END MP
""")
    # FL: LP reaches 20000, then 495 pulses of deceleration; RL: LP < -3000 first at -3001
    assert abs(vc.vars[1] - 20_495) <= 1
    assert abs(vc.vars[2] - (-3_001 - 495)) <= 1
    assert vc.vars[3:5] == [axis_io.ERR_SOFT_LIMIT_PLUS, axis_io.ERR_SOFT_LIMIT_MINUS]


def test_set_compare_disables_the_software_limit() -> None:
    m = model()
    m.io.set_slmt(X, 2000, -2000, 0, 0.0)
    m.io.set_compare(X, 0, 0, 50_000, 0.0)
    m.fixed_move(X, 10_000, 0.0)
    assert m.lp(X, 100.0) == 10_000
    assert m.io.error_code(X, 100.0) == 0
    m.io.clear_slmt(X, 100.0)
    m.io.set_slmt(X, 12_000, -2000, 1, 100.0)  # on EP, which runs 5000 ahead
    m.set_ep(X, 15_000, 100.0)
    m.fixed_move(X, 10_000, 100.0)
    # EP is already beyond FL when the + move starts: it stops at once with SOFT LIMIT+
    assert m.idle_at(X, 100.0) == 100.0
    assert m.lp(X, 100.0) == 10_000
    assert m.io.error_code(X, 100.0) == axis_io.ERR_SOFT_LIMIT_PLUS


# ---------------------------------------------------------------- stops and error codes


def test_stop_command_sets_soft_stop_and_clear_stop_resets_it() -> None:
    vc = run_machine("""MP 156
  CONTINUE_MOVE X, 5000
  TIMER 100
  STOP_SLOWLY X
  STOP_WAIT X
  VAR1 = GET_ERROR_CODE(X)
  VAR2 = GET_ERROR_CODE(Y)
  CLEAR_STOP X
  VAR3 = GET_ERROR
  STOP_SUDDENLY Y
  VAR4 = GET_ERROR
END MP
""")
    assert vc.vars[1:5] == [256, 0, 0, 0]  # stopping an idle axis stops no motion


def test_vector_stop_marks_the_interpolation_axes_until_clear_vstop() -> None:
    m = model()
    m.axis_assign(Y, Z, 0)
    m.line((10_000, 10_000), 0.0)
    m.vector_stop(0.5, sudden=True)
    codes = [m.io.error_code(a, 0.5) for a in (X, Y, Z)]
    assert codes == [0, axis_io.ERR_SOFT_STOP, axis_io.ERR_SOFT_STOP]
    assert m.axis_report(1, 0.5).stop_causes == axis_io.ERR_SOFT_STOP
    m.io.clear_vstop(0.5)
    assert m.io.error_state(0.5) == 0


def test_software_emergency_stop_and_its_clearing() -> None:
    m = model()
    m.fixed_move(X | Y, 100_000, 0.0)
    m.io.emergency_stop(True, 1.0)
    x_at = m.lp(X, 1.0)
    assert x_at == round(cruise_time(0) * 0 + 495 + (1.0 - 0.09) * 10_000)
    assert not m.busy(15, 1.0)
    assert all(m.axis_report(i, 1.0).error_code == axis_io.ERR_SOFT_EMG for i in range(4))
    assert m.axis_report(0, 1.0).stop_causes & axis_io.ERR_EMERGENCY
    assert m.io.emergency
    m.fixed_move(X, 1000, 1.0)  # refused while the emergency lasts
    m.io.clear_stop(X, 1.0)  # does not clear SOFT EMG
    assert m.lp(X, 5.0) == x_at and m.io.error_code(X, 5.0) == axis_io.ERR_SOFT_EMG
    m.io.clear_emergency(5.0)
    assert m.io.error_state(5.0) == 0
    m.fixed_move(X, 1000, 5.0)
    assert m.lp(X, 10.0) == x_at + 1000


def test_emergency_stop_type_1_decelerates_and_drops_queued_commands() -> None:
    m = model()
    m.fixed_move(X, 100_000, 0.0)
    m.fixed_move(X, 5_000, 0.0)  # queued behind the first move
    m.io.emergency_stop(False, 1.0)
    end = m.idle_at(X, 1.0)
    assert end == pytest.approx(1.09)
    assert abs(m.lp(X, end) - (495 + 9_100 + 495)) <= 1


def test_emg_input_and_servo_alarm() -> None:
    m = model()
    m.fixed_move(X | Y, 100_000, 0.0)
    m.io.set_emg_input(True, 0.5)
    assert not m.busy(15, 0.5)
    assert all(m.io.error_code(1 << i, 0.5) == axis_io.ERR_EMERGENCY for i in range(4))
    assert m.axis_report(2, 0.5).di_status & 0b1000
    m.fixed_move(Z, 100, 0.5)
    assert m.lp(Z, 2.0) == 0
    m.io.set_emg_input(False, 2.0)
    m.io.clear_stop(15, 2.0)
    assert m.io.error_state(2.0) == 0
    # ALARM: ignored while disabled, stops its own axis once enabled (3.12)
    m.fixed_move(X | Y, 10_000, 2.0)
    m.io.set_alarm_input(0, True, 2.5)
    assert m.busy(X, 2.5)
    m.io.set_alarm(X, 1, 0, 2.6)
    assert not m.busy(X, 2.6) and m.busy(Y, 2.6)
    assert m.io.error_code(X, 2.6) == axis_io.ERR_ALARM
    assert m.axis_report(0, 2.6).di_status & 0b10000


def test_servo_on_and_inpos_bits() -> None:
    vc = run_machine("""MP 156
  SERVO_ON XY
  SERVO_OFF Y
  VAR1 = GET_DI(X, 8)
  VAR2 = GET_DI(Y, 8)
  VAR3 = GET_DI_SIGNAL(X, 6)
END MP
""")
    assert vc.vars[1:4] == [0, 1, 1]  # table 25: 0 = on; table 27: 1 = on
    assert vc.motion.axis_report(0, vc.clock).servo_on
    assert not vc.motion.axis_report(1, vc.clock).servo_on


# -------------------------------------------------------------------------- home search


HOME_MACHINE = AxisSensors(limit_plus=500_000, limit_minus=-500_000,
                           near_home=(-30_000, -10_000), home=(-20_000, -19_000),
                           index_period=4000, index_offset=100)


def test_manual_6_3_home_mode_ends_offset_from_the_z_phase() -> None:
    vc = run_machine(f"""MP 156
  SET_SV X, 1000
  SET_V X, 20000
  SET_A X, 200000
  {example("RSM_MACRO_SET_HV")}
  FIXED_MOVE X, 100000
  STOP_WAIT X
  {example("RSM_MACRO_SET_HOME_MODE")}
  {example("RSM_MACRO_HOME_START")}
  VAR1 = GET_HOME_SEARCH_STATE(X)
  STOP_WAIT X
  VAR2 = GET_HOME_SEARCH_STATE(X)
  VAR3 = GET_LP(X)
  VAR4 = GET_EP(X)
  VAR5 = GET_ERROR
END MP
""", {0: HOME_MACHINE})
    assert vc.vars[1:6] == [3, 0, 0, 0, 0]
    io = vc.motion.io
    # step 1 (-) finds NHOME at -10000 and decelerates into it; step 2 (-) stops on HOME's
    # upper edge -19000; step 3 (+) on the next Z at -15900; step 4 (+) offsets 3500
    assert io.machine_position(0, vc.clock) == -15_900 + 3_500
    rep = vc.motion.axis_report(0, vc.clock)
    assert rep.home_end is not None and rep.home_end <= vc.clock
    assert io.triggered_factors(vc.clock)[axis_io.FACTOR_HMEND] == X


def search(m: MotionModel, mode: tuple[int, int, int, int, int], now: float) -> float:
    m.io.set_home_mode(X, *mode)
    m.io.home_start(X, now)
    end = m.idle_at(X, now)
    assert end is not None
    return end


def test_home_step2_irregular_operations() -> None:
    # (a) HOME active at the start: leave it backwards, then search it
    m = model(home=(-1000, 1000), index_period=None)
    states = []
    m.io.set_home_mode(X, 0, 2, 0, 0, 0)
    m.io.home_start(X, 0.0)
    states.append(m.io.home_state(X, 0.0))
    end = m.idle_at(X, 0.0)
    assert end is not None
    assert states == [axis_io.HOME_BACK_OFF]
    assert m.io.machine_position(0, end) == 1000
    # a counter changes half a pulse before the integer (LP rounds): LP 1001 at 1000.5,
    # then back to LP 1000 half a pulse later, all at HV = 500 PPS
    assert end == pytest.approx((1000.5 + 0.5) / 500)
    # (b) on the limit of the search direction: back up to HOME, through it, search again
    m = model(home=(-1000, 1000), index_period=None, limit_minus=-5000)
    m.abs_move(X, -5000, 0.0)
    t0 = m.idle_at(X, 0.0)
    assert t0 is not None
    assert m.io.error_code(X, t0) == axis_io.ERR_LIMIT_MINUS  # the target is on the switch
    m.io.clear_stop(X, t0)
    m.io.set_home_mode(X, 0, 2, 0, 0, 0)
    m.io.home_start(X, t0)
    # HOME on at 3999.5 pulses (7.999 s), off at 6000.5 (12.001 s), back on 1 ms later
    seen = [m.io.home_state(X, t0 + dt) for dt in (1.0, 10.0, 12.0015)]
    assert seen == [axis_io.HOME_BACK_ON, axis_io.HOME_BACK_OFF, axis_io.HOME_STEP2]
    end = m.idle_at(X, t0)
    assert end is not None
    assert m.io.machine_position(0, end) == 1000 and m.io.error_state(end) == 0
    # (c) reaching the limit during the search: stop, then as (b)
    m = model(home=(10_000, 11_000), index_period=None, limit_minus=-1000)
    m.io.set_home_mode(X, 0, 2, 0, 0, 0)
    m.io.home_start(X, 0.0)
    assert m.io.home_state(X, 1.0) == axis_io.HOME_STEP2
    assert m.io.home_state(X, 3.0) == axis_io.HOME_BACK_ON  # limit at 1.999 s
    end = m.idle_at(X, 3.0)
    assert end is not None
    assert m.io.machine_position(0, end) == 11_000 and m.io.error_state(end) == 0
    assert end == pytest.approx((999.5 + 10_999.5 + 1001 + 0.5) / 500)


def test_step_1_is_skipped_when_near_home_is_already_active() -> None:
    m = model(near_home=(-5000, 5000), home=(-2000, -1000), index_period=None)
    m.io.set_home_mode(X, 2, 2, 0, 0, 0)
    m.io.home_start(X, 0.0)
    assert m.io.home_state(X, 0.0) == axis_io.HOME_STEP2  # straight to step 2, at HV
    end = m.idle_at(X, 0.0)
    assert end == pytest.approx(999.5 / 500)
    assert m.io.machine_position(0, end) == -1000


def test_step_3_waits_for_the_next_z_edge_when_it_starts_on_one() -> None:
    m = model(home=None, index_period=1000, index_width=10)  # Z on at 0..9
    end = search(m, (0, 0, 2, 0, 0), 0.0)  # negative: off at -1, on again at -991
    assert m.io.machine_position(0, end) == -991
    m = model(home=None, index_period=1000, index_width=10)
    end = search(m, (0, 0, 1, 0, 0), 0.0)  # positive: off at 10, on again at 1000
    assert m.io.machine_position(0, end) == 1000


def test_home_limit_uses_the_limit_switch_as_home() -> None:
    m = model(home=None, index_period=None, limit_minus=-3000)
    m.io.home_limit(X, 1)
    end = search(m, (0, 2, 0, 1, 1000), 0.0)
    assert m.io.machine_position(0, end) == -2000
    assert (m.lp(X, end), m.ep(X, end), m.io.error_state(end)) == (0, 0, 0)


def test_home_error_when_z_and_home_are_both_active_at_step_3() -> None:
    m = model(home=(-1000, 1000), index_period=4000)  # Z at 0, inside HOME
    end = search(m, (0, 0, 1, 0, 0), 0.0)
    assert end == 0.0
    assert m.io.error_code(X, end) == axis_io.ERR_HOME
    assert m.axis_report(0, end).stop_causes == axis_io.ERR_HOME


def test_home_search_stopped_by_a_limit_in_step_3_reports_it() -> None:
    m = model(home=(-1000, 1000), index_period=None, limit_plus=5000)
    end = search(m, (0, 0, 1, 0, 0), 0.0)
    assert m.io.machine_position(0, end) == 5000
    assert m.io.error_code(X, end) == axis_io.ERR_LIMIT_PLUS
    assert m.lp(X, end) == 5000  # no clear after a failed search


def test_step_1_limit_leads_to_step_2_without_error() -> None:
    m = model(near_home=(50_000, 60_000), home=(-100, 100), limit_minus=-20_000,
              index_period=None)
    end = search(m, (2, 2, 0, 0, 0), 0.0)
    assert m.io.machine_position(0, end) == 100
    assert m.io.error_state(end) == 0


def test_stop_command_ends_a_home_search() -> None:
    m = model(near_home=(-30_000, -10_000), home=(-20_000, -19_000))
    m.io.set_home_mode(X, 2, 2, 1, 1, 100)
    m.io.home_start(X, 0.0)
    m.stop(X, 0.5, sudden=True)
    assert m.io.home_state(X, 0.5) == 0
    assert m.io.error_code(X, 0.5) == axis_io.ERR_SOFT_STOP
    assert not m.busy(X, 0.5)
    assert m.axis_report(0, 0.5).home_end == 0.5


@settings(max_examples=60, deadline=None)
@given(lo=st.integers(-5000, 5000), width=st.integers(0, 2000), start=st.integers(-9000, 9000),
       d2=st.sampled_from([1, 2]), d3=st.sampled_from([0, 1, 2]), d4=st.sampled_from([0, 1, 2]),
       offset=st.integers(0, 3000), period=st.integers(50, 3000), phase=st.integers(0, 3000))
def test_home_steps_2_to_4_end_where_the_sensors_dictate(
        lo: int, width: int, start: int, d2: int, d3: int, d4: int, offset: int, period: int,
        phase: int) -> None:
    hi = lo + width
    step = 1 if d2 == 1 else -1
    inside = lo <= start <= hi
    assume(inside or (step > 0 and start < lo) or (step < 0 and start > hi))
    m = model(home=(lo, hi), index_period=period, index_offset=phase)
    m.abs_move(X, start, 0.0)
    t0 = m.idle_at(X, 0.0)
    assert t0 is not None
    end = search(m, (0, d2, d3, d4, offset), t0)
    edge = lo if step > 0 else hi  # HOME's edge met in the search direction

    def z(p: int) -> bool:
        return (p - phase) % period == 0

    if d3 and z(edge):
        assert m.io.error_code(X, end) == axis_io.ERR_HOME
        assert m.io.machine_position(0, end) == edge
        return
    pos = edge
    if d3:
        s3 = 1 if d3 == 1 else -1
        pos += s3
        while not z(pos):
            pos += s3
    if d4:
        pos += offset if d4 == 1 else -offset
    assert m.io.machine_position(0, end) == pos
    assert (m.lp(X, end), m.ep(X, end), m.io.error_state(end)) == (0, 0, 0)


# -------------------------------------------------------------- compare and interrupts


def test_manual_7_3_12_compare_interrupts_at_c_plus() -> None:
    m = model()
    m.set_max_v(15, 5000)
    m.set_v(15, 2000)
    m.set_sv(15, 100)
    m.io.set_compare(X, 0, 0, 2000, 0.0)
    m.io.intfactor_enable(X, axis_io.INT_P_GE_CPLUS, 1, 0.0)
    m.io.enable_int(0.0)
    m.fixed_move(X, 16_000, 0.0)
    t1 = m.next_interrupt(0.0)
    assert t1 is not None
    # 100 -> 2000 PPS at 100000 PPS/s takes 0.019 s and 19.95 pulses; LP 2000 at 1999.5
    assert t1 == pytest.approx(0.019 + (1999.5 - 19.95) / 2000)
    assert m.take_interrupts(t1 - 1e-6) == []
    assert m.take_interrupts(t1) == [(t1, 1)]
    assert m.lp(X, t1) == 2000 and m.lp(X, t1 - 1e-9) == 1999
    assert m.io.triggered_factors(t1)[axis_io.INT_P_GE_CPLUS] == X
    # ISR1 moves C+ to 4000 and hands the factor to ISR2
    m.io.set_compare(X, 0, 0, 4000, t1)
    m.io.intfactor_enable(X, axis_io.INT_P_GE_CPLUS, 2, t1)
    assert m.io.triggered_factors(t1)[axis_io.INT_P_GE_CPLUS] == 0
    t2 = m.next_interrupt(t1)
    assert t2 == pytest.approx(t1 + 2000 / 2000)
    assert m.take_interrupts(100.0) == [(t2, 2)]
    assert m.next_interrupt(100.0) is None


def test_manual_7_3_12_13_examples_as_statements() -> None:
    vc = run_machine(f"""MP 156
  SET_SV X, 1000
  SET_V X, 10000
  SET_A X, 100000
  SET_COMPARE X, 0, 0, 5000
  {example("RSM_MACRO_INTFACTOR_ENABLE")}
  ENABLE_INT
  FIXED_MOVE X, 10000
  STOP_WAIT X
END MP
ISR 1
  VAR1 = GET_LP(X)
END ISR
""")
    io = vc.motion.io
    assert io.triggered_factors(vc.clock)[axis_io.INT_P_GE_CPLUS] == X
    # the controller dispatched ISR1 when X passed C+ (at 4999.5, where LP turns 5000) and
    # the ISR's first line ran one line time later, at 10000 pulses/s: one pulse further on
    assert vc.vars[1] == 5001
    assert vc.motion.take_interrupts(vc.clock) == []
    assert any("ISR1 started" in entry for entry in vc.log)
    io.intfactor_enable(X, axis_io.INT_P_GE_CPLUS, 1, vc.clock)
    source = example("RSM_MACRO_INTFACTOR_DISABLE")
    assert source == "INTFACTOR_DISABLE XYZU, 4"
    io.intfactor_disable(15, 4, vc.clock)
    assert io.cfg[0].int_factors == {}


def test_drive_factors_c_sta_c_end_d_end_and_disable_int() -> None:
    m = model()
    for factor in (axis_io.INT_C_END, axis_io.INT_C_STA, axis_io.INT_D_END):
        m.io.intfactor_enable(X, factor, 10 + factor, 0.0)
    m.fixed_move(X, 10_000, 0.0)
    assert m.next_interrupt(0.0) is None  # ENABLE_INT not given yet
    m.io.enable_int(0.0)
    end = m.idle_at(X, 0.0)
    # 8 offset pulses (the power-on AO) run at SV after the deceleration
    assert end == pytest.approx(0.18 + (10_000 - 8 - 990) / 10_000 + 0.008)
    got = m.take_interrupts(end)
    assert got == [(pytest.approx(0.09), 16), (pytest.approx(end - 0.008 - 0.09), 15),
                   (pytest.approx(end), 17)]
    m.io.disable_int(end)
    m.fixed_move(X, 10_000, end)
    assert m.take_interrupts(end + 10) == []


def test_pulse_factor_asks_for_one_isr_at_a_time() -> None:
    m = model()
    m.io.intfactor_enable(Y, axis_io.INT_PULSE, 3, 0.0)
    m.io.enable_int(0.0)
    m.fixed_move(Y, -1000, 0.0)
    t1 = m.next_interrupt(0.0)
    # LP becomes -1 when 1000 t + 50000 t^2 passes 0.5
    assert t1 == pytest.approx((-1000 + math.sqrt(1000**2 + 4 * 50_000 * 0.5)) / 1e5)
    assert len(m.take_interrupts(0.01)) == 1  # many pulses, one pending request
    t2 = m.next_interrupt(0.01)
    assert t2 is not None and t2 > 0.01
    assert m.lp(Y, t2) == m.lp(Y, 0.01) - 1


def test_interrupt_prediction_sees_a_stop_before_the_compare_value() -> None:
    m = model(limit_plus=3000)
    m.io.set_compare(X, 0, 0, 5000, 0.0)
    m.io.intfactor_enable(X, axis_io.INT_P_GE_CPLUS, 1, 0.0)
    m.io.intfactor_enable(X, axis_io.INT_D_END, 2, 0.0)
    m.io.enable_int(0.0)
    m.fixed_move(X, 10_000, 0.0)
    when = m.next_interrupt(0.0)
    assert when == pytest.approx(cruise_time(2999.5))  # D-END of the limit stop, not C+
    assert m.take_interrupts(when) == [(when, 2)]


# ---------------------------------------------------------------- synchronous actions


def test_manual_7_3_1_example_2_compare_starts_another_axis() -> None:
    m = model()
    m.set_max_v(Y | U, 9000)
    m.set_v(Y | U, 3000)
    m.set_a(Y | U, 200_000)
    m.set_sv(Y | U, 200)
    m.io.sync_action(U, Y, 0x01, 1, 0, 3, 0, 0, (0, 0, 0, 0), 0.0)
    m.io.set_compare(U, 0, 1, 5000, 0.0)  # COMP+ 5000 on U's EP
    m.io.set_preset(Y, 2000)
    m.fixed_move(U, 10_000, 0.0)
    # 200 -> 3000 PPS at 200000: 0.014 s, 22.4 pulses; EP 5000 at 4999.5
    hit = 0.014 + (4999.5 - 22.4) / 3000
    assert m.lp(Y, hit - 1e-6) == 0 and m.busy(Y, hit)
    end = m.idle_at(Y, hit)
    assert end is not None and m.lp(Y, end) == 2000
    assert m.io.triggered_factors(end)[axis_io.FACTOR_SYNC] == Y


def test_manual_7_3_1_example_4_compare_stops_the_axis_and_interrupts() -> None:
    m = model()
    m.io.sync_action(X, X, 0x01, 6, 0, 0, 0, 1, (1, 0, 0, 0), 0.0)
    m.io.enable_int(0.0)
    m.io.set_compare(X, 0, 0, 5000, 0.0)
    m.fixed_move(X, 10_000, 0.0)
    when = m.next_interrupt(0.0)
    assert when == pytest.approx(cruise_time(4999.5))
    assert m.idle_at(X, 0.0) == pytest.approx(when)
    assert m.lp(X, when) == 5000
    assert m.take_interrupts(when) == [(when, 1)]
    assert m.io.error_state(when) == 0  # ISTOP is no stop command


def test_manual_7_3_1_example_1_in3_latches_ep_and_sets_the_speed() -> None:
    vc = run_machine(f"""MP 156
  {example("RSM_MACRO_SYNC_ACTION")}
  {example("RSM_MACRO_SET_PRESET")}
  SET_SV U, 100
  SET_V U, 2000
  SET_A U, 100000
  SET_EP U, 7
  FIXED_MOVE U, 10000
END MP
""")
    m = vc.motion
    m.io.set_in3(3, 0, 1.0)
    assert m.io.latch(U, 1.0) == 0  # IN3 falling is not a factor here
    m.io.set_in3(3, 1, 2.0)
    assert m.io.latch(U, 2.0) == m.ep(U, 2.0) == m.lp(U, 2.0) + 7
    assert m.settings[3].v == 100
    assert m.axis_report(3, 2.0).di_status >> 7 & 1 == 1  # IN3 high = off


def test_latch_by_lp_and_clear_sync_action() -> None:
    vc = run_machine(f"""MP 156
  {example("RSM_MACRO_SET_ACTIVATION_FACTORS")}
  {example("RSM_MACRO_SET_ACTIVATION_AXIS")}
  SET_ACTION Y, 0, 1, 0, 0, 0, 0, 0, 0, 0
  SET_COMPARE X, 0, 0, 3000
  FIXED_MOVE Y, 1234
  STOP_WAIT Y
  FIXED_MOVE X, 10000
  STOP_WAIT X
  VAR1 = GET_LATCH(Y)
  FIXED_MOVE Y, 1000
  STOP_WAIT Y
  CLEAR_SYNC_ACTION X
  FIXED_MOVE X, -10000
  STOP_WAIT X
  FIXED_MOVE X, 10000
  STOP_WAIT X
  VAR2 = GET_LATCH(Y)
END MP
""")
    # X passing LP 3000 latches Y's LP; once cleared, the second pass latches nothing
    assert vc.vars[1:3] == [1234, 1234]
    assert vc.motion.lp(Y, vc.clock) == 2234


def test_report_words_follow_tables_25_to_27() -> None:
    m = model(near_home=(-10, 10), home=(-1, 1), index_period=100)
    rep = m.axis_report(0, 0.0)
    # at 0: NHOME, HOME and INDEX on (0), IN3 off (1), INPOS off (servo off)
    assert rep.di_status == 0b0110000000
    assert rep.di_signal == 0b00001000
    assert (rep.stopped, rep.driving, rep.emergency, rep.home_state) == (True, False, False, 0)
    m.io.set_sensors(0, NO_SENSORS, 0.0)
    assert m.axis_report(0, 0.0).di_status == 0b1111100000
