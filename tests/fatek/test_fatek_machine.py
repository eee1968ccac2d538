"""The virtual FBs-PLC runs the manual's listings with the motion the manual describes, the
home-return modes, the transitions and the PLC's errors; (hypothesis) any table of relative
moves ends at the sum of its strokes."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.fatek import FamilyRun, check_native, run_build
from mplang.fatek.machine import Machine, PlcError, axis_params
from mplang.fatek.model import Contact, ParamTable, PositioningTable, Register
from mplang.fatek.parser import parse_text
from mplang.fatek.profile import load
from mplang.fatek.run import NoSuchTable
from mplang.lang.diagnostics import DiagnosticSink
from mplang.m8194h.run import NoSuchProgram, RunSetupError

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "fatek"


def run_text(text: str, call: str | None = None, max_time: float = 600.0) -> FamilyRun:
    path = Path("t.fbs")
    build = check_native([path], texts={path: text})
    assert build.ok, [d.render() for d in build.diagnostics]
    return run_build(build, call, max_time)


def run_sample(name: str, max_time: float = 600.0) -> FamilyRun:
    return run_build(check_native([SAMPLES / name]), None, max_time)


def speed_at(run: FamilyRun, when: float, axis: int = 0) -> float:
    for leg in run.legs:
        if leg.t0 <= when < leg.t_end and axis in leg.unit:
            return leg.speed(when) * abs(leg.unit[axis])
    return 0.0


def x(run: FamilyRun) -> int:
    return run.positions[0]


@pytest.mark.parametrize("path", sorted(SAMPLES.glob("*.fbs")), ids=lambda p: p.name)
def test_every_manual_listing_runs_without_a_plc_error(path: Path) -> None:
    run = run_build(check_native([path]), None, 20.0)
    assert run.finished or not (run.error or "").startswith("PLC error"), run.error
    assert run.legs and run.samples[-1][0] == run.time_s


def test_the_drvc_example_ends_at_the_summed_distance_with_the_stated_speeds() -> None:
    run = run_sample("drvc_three_speeds.fbs")
    assert x(run) == 20_000 + 60_000 + 5_000
    (leg,) = run.legs
    first, second = leg.boundaries
    assert speed_at(run, first / 2) == pytest.approx(10_000)
    assert speed_at(run, (first + second) / 2) == pytest.approx(50_000)
    assert speed_at(run, (second + leg.t_end) / 2) == pytest.approx(3_000)
    assert not run.finished and "waits for X0" in (run.error or "")
    assert run.registers[Register("R", 4064)] == 3  # step number at the end of the step


def test_the_format_example_cuts_at_the_deceleration_point_and_outputs_the_rest() -> None:
    run = run_sample("format_example.fbs")
    # +10000, +30000 (DD100), -35000 (DD102) cut at 20000 by X0, then the 15000 left (DR4072)
    assert x(run) == 5_000
    step4 = run.legs[3]
    assert step4.start[0] == 20_000
    assert step4.speed(step4.t0) == pytest.approx(10_000)  # the speed of step 3 carries over
    assert speed_at(run, step4.t_end - 0.5) == pytest.approx(2_000)
    assert run.legs[1].t0 - run.legs[0].t_end == pytest.approx(1.0)  # WAIT TIME,100
    assert run.legs[2].t0 - run.legs[1].t_end == pytest.approx(0.5)  # WAIT TIME,R500 = 50
    assert "waits for X1" in (run.error or "")


def test_the_fun147_example_moves_four_axes_along_lines() -> None:
    run = run_sample("fun147_format_example.fbs")
    assert run.positions == (3_500, -3_600, 1_800, -600)
    first = run.legs[0]
    assert first.targets == {0: 500, 1: 400, 2: 300, 3: 200}
    # 735 pulses of line: it ramps at 5000 Hz per parameter-13 time (500 ms) and never gets
    # to 5 kHz before it must slow down again
    assert first.speed(first.t0 + 0.1) == pytest.approx(1_000)
    assert first.speed((first.t0 + first.t_end) / 2) < 5_000
    assert run.registers[Register("D", 4062)] == 3


def test_the_jog_runs_to_mend_and_sets_the_completion_relay() -> None:
    run = run_sample("jog_forward.fbs")
    assert run.finished and run.error is None
    assert x(run) == 1 + 999_999
    assert Contact("M", 1996) in run.relays
    assert run.registers[Register("R", 2000)] == 2  # WR+0: the step it stands on
    assert run.to_json()["vars"]["R2000"] == 2


def test_example_6_returns_to_its_start_and_waits_for_m200() -> None:
    run = run_sample("example6_cycle.fbs")
    assert x(run) == 0
    assert run.legs[2].t0 == pytest.approx(25.0)  # WAIT M200, ON at 25 s (SIM)
    assert "X16" in (run.error or "")


def test_the_coordinates_example_works_in_millimetres() -> None:
    run = run_sample("coordinates.fbs")
    assert run.finished and x(run) == 0
    assert max(p["X"] for _, p in run.samples) == 300 * 200  # 300 mm at 200 Ps/mm


def test_the_adr_and_abs_pairs_reach_the_same_places() -> None:
    run = run_sample("adr_abs_pairs.fbs")
    ends = [round(leg.position(0, leg.t_end)) for leg in run.legs]
    assert ends == [30_000, -10_000, 10_000, 30_000, -10_000, 10_000]


def test_home_method_1_stops_at_the_near_point_then_creeps() -> None:
    run = run_sample("home_method_1.fbs")
    assert run.finished
    assert round(run.legs[0].position(0, run.legs[0].t_end)) == -50_000
    assert x(run) == -50_000 - 9_999


HOME = """TABLE p FUN141 Ps0
P6 = 1000
P15 = {p15}
P16 = 100
P17 = 4
TABLE h FUN140 Ps0
001 SPD 5000
    DRVZ MD{mode}
    MEND
SIM X0 ON WHILE Ps0 IN -30000..-20000
SIM X4 PULSE Ps0 EVERY 500
{extra}"""


def home(mode: int, p15: str = "0804FF00H", extra: str = "") -> FamilyRun:
    return run_text(HOME.format(mode=mode, p15=p15, extra=extra))


def test_drvz_md0_creeps_through_the_dog_and_takes_its_far_edge() -> None:
    run = home(0)
    assert run.finished and x(run) == 100  # parameter 16 (FB 3508-3511)
    assert round(run.legs[-1].position(0, run.legs[-1].t_end)) == -30_000
    assert speed_at(run, run.legs[-1].t_end - 0.1) == pytest.approx(1_000)
    assert run.time_s == pytest.approx(run.legs[-1].t_end + 0.02)  # CLR Y8 for 20 ms


def test_drvz_md1_brakes_waits_and_backs_out_slowly() -> None:
    run = home(1)
    brake, back = run.legs[-2], run.legs[-1]
    assert brake.speed(brake.t_end - 1e-6) < 100
    assert back.t0 - brake.t_end == pytest.approx(0.5)
    assert back.unit[0] > 0 and round(back.position(0, back.t_end)) == -20_000
    assert x(run) == 100


def test_drvz_md2_counts_pg0_from_either_edge_of_the_dog() -> None:
    leading = home(2)
    assert round(leading.legs[-1].position(0, leading.legs[-1].t_end)) == -20_000 - 4 * 500
    trailing = home(2, "0884FF00H")  # b7 of 15-2: count from the trailing edge
    assert round(trailing.legs[-1].position(0, trailing.legs[-1].t_end)) == -30_000 - 4 * 500
    assert leading.finished and trailing.finished and x(trailing) == 100


def test_drvz_from_past_the_dog_uses_the_limit_input() -> None:
    # DOG X0 at -30000..-20000, limit X1 at -50000..-45000 (15-1 = X1, NO); the table first
    # goes to -40000, past the DOG, so the home return meets the limit and comes back
    text = """TABLE p FUN141 Ps0
P15 = 08040100H
P16 = 100
TABLE h FUN140 Ps0
001 SPD 5000
    DRV ABS,,-40000,Ps
    WAIT TIME,0
    GOTO NEXT
002 SPD 5000
    DRVZ MD0
    MEND
SIM X0 ON WHILE Ps0 IN -30000..-20000
SIM X1 ON WHILE Ps0 IN -50000..-45000
"""
    run = run_text(text)
    assert run.finished and x(run) == 100
    turns = [round(leg.position(0, leg.t_end)) for leg in run.legs[1:]]
    assert turns[0] == -45_000  # the limit
    assert turns[-1] == -30_000  # the DOG's far edge, reached going toward the origin again


def test_drvz_without_a_sensor_for_its_dog_is_an_error_of_the_run() -> None:
    no_sensor = run_text(HOME.format(mode=0, p15="0804FF03H", extra=""))
    assert not no_sensor.finished and "X3" in (no_sensor.error or "")


def test_the_plc_itself_refuses_drvz_without_a_dog_input() -> None:
    # the checker reports this (E619); the virtual PLC raises error 51 as the PLC would
    sink = DiagnosticSink()
    parsed = parse_text(HOME.format(mode=0, p15="08FFFFFFH", extra=""), "t.fbs", sink)
    params, table = parsed.tables
    assert isinstance(params, ParamTable) and isinstance(table, PositioningTable)
    table.fun = 140
    profile = load()
    machine = Machine(profile, table, axis_params(profile, [params]), parsed.sim, 60.0)
    with pytest.raises(PlcError) as caught:
        machine.run(1)
    assert caught.value.code == 51


def test_ext_already_on_ends_the_step_at_once() -> None:
    text = ("001 SPD 1000\n DRV ADR,+,5000,Ps\n EXT X2\n GOTO NEXT\n"
            "002 SPD 1000\n DRV ADR,-,100,Ps\n MEND\nSIM X2 ON AT 0\n")
    run = run_text(text)
    assert x(run) == -100
    assert run.registers.get(Register("R", 4072), 0) == 0


def test_act_cuts_a_long_move_and_waits_after_a_short_one() -> None:
    long_move = run_text("001 SPD 1000\n DRV ADR,+,100000,Ps\n ACT TIME,200\n GOTO NEXT\n"
                         "002 SPD 1000\n DRV ADR,-,10,Ps\n MEND\n")
    assert long_move.legs[0].t_end == pytest.approx(2.0)
    assert 1_500 < x(long_move) + 10 < 2_000
    short = run_text("001 SPD 1000\n DRV ADR,+,10,Ps\n ACT TIME,200\n GOTO NEXT\n"
                     "002 SPD 1000\n DRV ADR,-,10,Ps\n MEND\n")
    assert short.legs[1].t0 == pytest.approx(2.0) and x(short) == 0


def test_register_operands_and_their_errors() -> None:
    base = "001 SPD R100\n DRV ADR,,D10,Ps\n WAIT TIME,0\n GOTO R50\n002 SPD 5\n DRV ADR,+,1,Ps\n" \
           " MEND\n"
    good = run_text(base + "SIM DR100 = 2000\nSIM DD10 = -3000\nSIM R50 = 2\n")
    assert good.finished and x(good) == -2_999
    zero = run_text(base)
    assert "waits for a speed" in (zero.error or "")
    bad_goto = run_text(base + "SIM DR100 = 2000\nSIM DD10 = 5\nSIM R50 = 9\n")
    assert (bad_goto.error or "").startswith("PLC error 34")
    fast = run_text(base + "SIM DR100 = 2000000\n")
    assert (fast.error or "").startswith("PLC error 31")
    assert fast.registers[Register("R", 4060)] == 31


def test_a_loop_runs_until_max_time() -> None:
    run = run_text("001 SPD 1000\n DRV ADR,+,100,Ps\n WAIT TIME,0\n GOTO NEXT\n", max_time=5.0)
    assert not run.finished and "5 s" in (run.error or "")
    assert run.time_s == pytest.approx(5.0)
    assert x(run) >= 400  # GOTO NEXT after the last step wraps to step 1


def test_a_continuous_run_that_nothing_ends_is_reported() -> None:
    run = run_text("001 SPD 1000\n DRV ADR,+,0,Ps\n MEND\n", max_time=2.0)
    assert "runs for ever" in (run.error or "")
    assert 1_500 < x(run) < 2_000


def test_calls_pick_a_table_and_an_entry_step() -> None:
    text = "TABLE a FUN140 Ps1\n001 SPD 1000\n DRV ADR,+,10,Ps\n WAIT TIME,0\n GOTO NEXT\n" \
           "002 SPD 1000\n DRV ADR,+,5,Ps\n MEND\nTABLE p FUN141 Ps1\nP8 = 0\n"
    assert run_text(text).positions[1] == 15
    second = run_text(text, "A:2")
    assert second.positions[1] == 5 and second.called == "a:2"
    for call, message in (("nope", "no table named"), ("p", "parameter table"),
                          ("a:3", "steps 1-2")):
        with pytest.raises(NoSuchTable, match=message):
            run_text(text, call)
    assert issubclass(NoSuchTable, NoSuchProgram)


def test_a_build_with_errors_does_not_run() -> None:
    path = Path("bad.fbs")
    build = check_native([path], texts={path: "001 SPD 0\n DRV ADR,+,1,Ps\n MEND\n"})
    with pytest.raises(RunSetupError):
        run_build(build)


def test_run_json_has_the_m8194h_keys() -> None:
    summary = run_sample("jog_backward.fbs").to_json()
    assert set(summary) == {"called", "vars", "names", "axes", "time_ms", "error"}
    assert summary["axes"] == {"X": {"lp": -1_000_000, "ep": -1_000_000},
                               "Y": {"lp": 0, "ep": 0}, "Z": {"lp": 0, "ep": 0},
                               "U": {"lp": 0, "ep": 0}}


def test_samples_cover_every_millisecond_and_every_segment_end() -> None:
    run = run_sample("drvc_three_speeds.fbs")
    times = [t for t, _ in run.samples]
    assert times == sorted(times) and times[0] == 0.0
    (leg,) = run.legs
    for boundary in (*leg.boundaries, leg.t_end):
        assert any(abs(t - boundary) < 1e-12 for t in times)
    moving = [t for t in times if t <= leg.t_end]
    assert max(b - a for a, b in itertools.pairwise(moving)) <= 0.001 + 1e-9
    assert run.samples[-1][1]["X"] == 85_000


strokes = st.lists(st.integers(-5_000, 5_000).filter(bool), min_size=1, max_size=8)


@settings(max_examples=60, deadline=None)
@given(strokes, st.integers(2_000, 921_600), st.integers(0, 30_000))
def test_relative_moves_end_at_the_sum_of_their_strokes(moves: list[int], speed: int,
                                                        ramp_ms: int) -> None:
    lines = [f"TABLE p FUN141 Ps0\nP8 = {ramp_ms}\nP4 = 921600\nTABLE m FUN140 Ps0"]
    for number, stroke in enumerate(moves, start=1):
        last = number == len(moves)
        lines.append(f"{number:03d} SPD {speed}\n DRV ADR,,{stroke},Ps\n"
                     + (" MEND" if last else " WAIT TIME,1\n GOTO NEXT"))
    run = run_text("\n".join(lines) + "\n", max_time=1e6)
    assert run.finished and x(run) == sum(moves)
    times = [t for t, _ in run.samples]
    assert times == sorted(times)
    for leg in run.legs:
        assert leg.speed((leg.t0 + leg.t_end) / 2) <= speed + 1e-6


def test_the_sample_period_sets_the_grid_and_changes_nothing_else() -> None:
    build = check_native([SAMPLES / "jog_forward.fbs"])
    fine, coarse = run_build(build, None, 600.0), run_build(build, None, 600.0,
                                                            sample_period=0.01)
    bare = run_build(build, None, 600.0, sample_period=None)
    assert fine.to_json() == coarse.to_json() == bare.to_json()
    assert fine.samples[-1] == coarse.samples[-1] == bare.samples[-1]
    assert 9 < len(fine.samples) / len(coarse.samples) < 11
    assert len(bare.samples) < 10  # leg starts and ends only
    with pytest.raises(ValueError, match="positive"):
        run_build(build, None, 600.0, sample_period=0.0)
