"""Every program of the CSIM manual (samples/csim/*.csim, transcribed with their CS lines)
parses, checks clean and runs on the virtual CSIM with the motion the manual describes."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from mplang import csim
from mplang.csim.run import FamilyRun

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "csim"
SCRIPTS = sorted(SAMPLES.glob("*.csim"))


def run(name: str, **kwargs: object) -> FamilyRun:
    build = csim.check_native([SAMPLES / name])
    assert build.ok and not build.diagnostics, [d.render() for d in build.diagnostics]
    return csim.run_build(build, None, 100.0, **kwargs)  # type: ignore[arg-type]


def axes(outcome: FamilyRun) -> dict[str, float]:
    report = outcome.to_json()["axes"]
    assert isinstance(report, dict)
    return {name: value["lp"] for name, value in report.items()}


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_every_sample_checks_clean_cites_the_manual_and_runs(path: Path) -> None:
    text = path.read_text("utf-8")
    assert "CS " in text.split("\n", 1)[0], "the first line names the manual's lines"
    outcome = run(path.name)
    assert outcome.finished and outcome.error is None


def test_ma_10000() -> None:
    outcome = run("ma_10000.csim")
    assert axes(outcome)["X"] == 10000
    assert math.isclose(outcome.time_s, 10.1, abs_tol=0.01)  # VM 1000, PR2 10000


def test_single_axis_moves() -> None:
    result = axes(run("single_axis.csim"))
    assert (result["X"], result["Z"]) == (5000, 200)


def test_2ma_starts_and_arrives_together() -> None:
    outcome = run("two_axis_2ma.csim")
    assert (axes(outcome)["X"], axes(outcome)["Y"]) == (100, 50)
    moving = [(t, p) for t, p in outcome.samples if 0 < p["X"] < 100]
    for _, position in moving:  # on the straight line y = x / 2 all the way
        assert math.isclose(position["Y"], position["X"] / 2, abs_tol=1e-6)
    first_x = min(t for t, p in outcome.samples if p["X"] > 0)
    first_y = min(t for t, p in outcome.samples if p["Y"] > 0)
    assert first_x == first_y


@pytest.mark.parametrize(("name", "centre", "turns"), [
    ("arc_360.csim", (100, 100), 1), ("arc_minus_720.csim", (50, 150), -2)])
def test_arcs_turn_around_their_centre(name: str, centre: tuple[int, int], turns: int) -> None:
    outcome = run(name)
    assert (axes(outcome)["X"], axes(outcome)["Y"]) == (0, 0)
    radius = math.hypot(*centre)
    angles = []
    for _, position in outcome.samples:
        distance = math.hypot(position["X"] - centre[0], position["Y"] - centre[1])
        assert math.isclose(distance, radius, rel_tol=1e-9)
        angles.append(math.atan2(position["Y"] - centre[1], position["X"] - centre[0]))
    swept = sum(math.remainder(b - a, 2 * math.pi) for a, b in itertools.pairwise(angles))
    assert math.isclose(swept, turns * 2 * math.pi, rel_tol=1e-6)


def test_jog_runs_until_jg0() -> None:
    result = axes(run("jog.csim"))
    assert 480 < result["X"] < 520 and -320 < result["Y"] < -280


def test_home_and_coordinates() -> None:
    outcome = run("home_and_coordinates.csim")
    assert (axes(outcome)["X"], axes(outcome)["Y"]) == (0, 0)
    # CS 100 renamed 800 as 100: homing runs the coordinate down to -700 (machine zero),
    # which then becomes 0.
    assert min(p["X"] for _, p in outcome.samples) == pytest.approx(-700, abs=0.1)


def test_outputs() -> None:
    outcome = run("outputs.csim")
    assert outcome.machine.outputs == [False, True, True, False]


def test_program_flow() -> None:
    outcome = run("program_flow.csim")
    assert outcome.to_json()["vars"] == {"N2": 3, "N3": 7, "R1": 1.5}
    assert axes(outcome)["X"] == 400


def test_event_handler_pauses_the_move() -> None:
    outcome = run("event_ppz.csim")
    report = outcome.to_json()
    assert report["vars"] == {"N0": 1, "N5": 1}
    assert 1000 < axes(outcome)["X"] < 1100  # one second at VM 1000, then braked


def test_variables() -> None:
    outcome = run("variables.csim")
    assert outcome.to_json()["vars"] == {"N0": 100, "N64": 7, "R0": 0.1, "R64": 0.25,
                                         "NS(2000)": 32766, "RS(0)": 2.5}
    assert outcome.machine.r[0] != 0.1  # stored as a 32-bit real
    assert outcome.printed == ["100", "variables set"]


def test_coordinated_commands() -> None:
    outcome = run("coordinated.csim")
    assert axes(outcome) == {"X": 60, "Y": 10, "Z": 10, "U": 400}
    assert outcome.machine.module_params[2]["PR3"] == 300  # TVM overrode T2PR3=200


def corner_speeds(outcome: FamilyRun) -> list[float]:
    """Path speed estimated at the corner samples of the octagon."""
    samples = outcome.samples
    speeds = []
    for (t0, a), (t1, b) in itertools.pairwise(samples):
        if t1 > t0:
            speeds.append(math.hypot(b["X"] - a["X"], b["Y"] - a["Y"]) / (t1 - t0))
    return speeds


def test_octagon_runs_in_one_go_in_cm2_with_pr7_above_45(tmp_path: Path) -> None:
    blended = run("octagon_cm2.csim")
    assert (axes(blended)["X"], axes(blended)["Y"]) == (0, 0)
    text = (SAMPLES / "octagon_cm2.csim").read_text().replace("PR7=50", "PR7=40")
    slow = tmp_path / "octagon_pr7_40.csim"
    slow.write_text(text)
    stopped = csim.run_build(csim.check_native([slow]), None, 100.0)
    assert blended.time_s < stopped.time_s - 0.3  # 7 stops fewer
    middle = [v for t, v in zip([t for t, _ in blended.samples[1:]], corner_speeds(blended),
                                strict=False) if 0.2 < t < blended.time_s - 0.2]
    assert min(middle) > 900  # never slows down between the segments (PR3 = 1000)


def test_helix() -> None:
    outcome = run("helix.csim")
    assert axes(outcome) == {"X": 100, "Y": 0, "Z": 40, "U": 0}
    highest_y = max(p["Y"] for _, p in outcome.samples)
    assert math.isclose(highest_y, 50, abs_tol=0.5)


def test_pause_and_buffer_control() -> None:
    outcome = run("pause_resume.csim")
    assert (axes(outcome)["X"], axes(outcome)["Y"]) == (1000, 1000)
    pauses = [t1 - t0 for (t0, a), (t1, b) in zip(outcome.samples, outcome.samples[1:],
                                                   strict=False) if a == b and 0 < a["X"] < 1000]
    assert pauses and max(pauses) > 0.09, "TAPZ holds the axes still until TAREDO"
