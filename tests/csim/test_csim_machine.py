"""The virtual CSIM's interpreter: semantics of the lines, run errors, and properties."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang import csim
from mplang.csim.run import FamilyRun, NoSuchProgram, RunSetupError


def run_text(tmp_path: Path, text: str, call: str | None = None, max_time: float = 100.0,
             **kwargs: object) -> FamilyRun:
    path = tmp_path / "t.csim"
    path.write_text(text)
    build = csim.check_native([path])
    assert build.ok, [d.render() for d in build.diagnostics]
    return csim.run_build(build, call, max_time, **kwargs)  # type: ignore[arg-type]


def test_run_errors_stop_the_program_with_the_line(tmp_path: Path) -> None:
    cases = {
        "2MA 1,2\n": "line 0 '2MA 1,2': logical axis X has no module",
        "TX=1\nT1MA 5\n": "T1 is logical axis X: point-to-point commands may not drive it",
        "TX=0\nTY=1\nT1PR3=5\n2MA 1,1\n": "PR2 and PR3 must be the same",
        "HOFF\nMA 5\n": "T0 is not held (HOFF)",
        "N1=32766\nN1=N1+1\n": "32767 does not fit N1",
        "N1=0\nN2=5/N1\n": "division by zero",
        "R1=1000000\n$A\nR1=R1*1000000\nJP $A\n": "1e+42 does not fit a 32-bit real",
        "SPI 1,2,3,4\n": "SPI is not modelled",
        "WI 1\n": "'WI 1' waits for ever",
        "GETI N1\n": "'GETI N1' waits for ever",
        "$A\nJP $A\n": "still running after 10 s",
    }
    for text, message in cases.items():
        outcome = run_text(tmp_path, text, max_time=10.0)
        assert not outcome.finished
        assert outcome.error is not None and message in outcome.error, (text, outcome.error)


def test_line_limit(tmp_path: Path) -> None:
    outcome = run_text(tmp_path, "$A\nJP $A\n", max_time=1.0)
    machine = outcome.machine
    machine.start(0)
    machine.run(max_time=100.0, max_steps=machine.steps + 500)
    assert machine.error is not None and "more than" in machine.error


def test_time_limit(tmp_path: Path) -> None:
    outcome = run_text(tmp_path, "MA 100000\nDN\n", max_time=5.0)
    assert not outcome.finished and "after 5 s" in (outcome.error or "")


def test_inputs_and_timed_jumps(tmp_path: Path) -> None:
    text = "WI 2\nJI 2,$ON\nN1=1\nRET\n$ON\nN1=2\nJNTI 2,100,$NEVER\nN2=3\n$NEVER\n"
    outcome = run_text(tmp_path, text, inputs={2: True})
    assert outcome.to_json()["vars"] == {"N1": 2, "N2": 3}
    assert outcome.time_s > 0.1  # JNTI waited its 100 ms


def test_integer_division_truncates_and_reals_are_float32(tmp_path: Path) -> None:
    outcome = run_text(tmp_path, "N1=-7\nN2=N1/2\nR1=1\nR2=R1/3\nN3=R2*10\n")
    variables = outcome.to_json()["vars"]
    assert isinstance(variables, dict)
    assert variables["N2"] == -3 and variables["N3"] == 3
    assert outcome.machine.r[2] == pytest.approx(1 / 3, rel=1e-7)
    assert outcome.machine.r[2] != 1 / 3


def test_event_returns_to_the_interrupted_wait(tmp_path: Path) -> None:
    text = ("SET EV2 NZ,N4\nON EV2,$H\nWT 100\nN4=1\nWT 50\nN1=N1+10\nRET\n"
            "$H\nN1=N1+1\nN4=0\nRET\n")
    outcome = run_text(tmp_path, text)
    assert outcome.to_json()["vars"] == {"N1": 11}


def test_tvm_changes_the_speed_of_a_running_coordinated_move(tmp_path: Path) -> None:
    slow = run_text(tmp_path, "TX=0\nTY=1\n2MR 3000,0\nDN\n")
    fast = run_text(tmp_path, "TX=0\nTY=1\n2MR 3000,0\nWT 500\nTVM=3000\nDN\n")
    assert slow.to_json()["axes"] == fast.to_json()["axes"]
    assert fast.time_s < slow.time_s - 1


def test_cm1_blends_and_cm0_stops(tmp_path: Path) -> None:
    moves = "TX=0\nTY=1\n2MR 500,0\n2MR 0,500\n2MR -500,0\nDN\n"
    stopped = run_text(tmp_path, "CM 0\n" + moves)
    blended = run_text(tmp_path, "CM 1\n" + moves)
    assert stopped.to_json()["axes"] == blended.to_json()["axes"]
    assert blended.time_s < stopped.time_s - 0.15


def test_call_entries(tmp_path: Path) -> None:
    text = "N1=1\nRET\n$SECOND\nN1=2\nRET\n"
    assert run_text(tmp_path, text, "$SECOND").to_json()["vars"] == {"N1": 2}
    assert run_text(tmp_path, text, "t:second").called == "t:$SECOND"
    assert run_text(tmp_path, text, "t").to_json()["vars"] == {"N1": 1}
    with pytest.raises(NoSuchProgram):
        run_text(tmp_path, text, "$THIRD")
    with pytest.raises(RunSetupError):
        run_text(tmp_path, text, inputs={9: True})


def test_samples_every_millisecond_and_at_every_segment_end(tmp_path: Path) -> None:
    outcome = run_text(tmp_path, "MR 100\nMR 50\nDN\n")
    times = [t for t, _ in outcome.samples]
    assert times == sorted(times)
    assert max(b - a for a, b in itertools.pairwise(times)) <= 0.001 + 1e-9
    ends = [t for t, p in outcome.samples if p["X"] in (100.0, 150.0)]
    assert ends, "the segment ends are samples"


MOVES = st.lists(st.tuples(st.sampled_from(["MR", "T1MR", "T2MA", "XMR"]),
                           st.integers(-5000, 5000)), min_size=1, max_size=8)


@settings(max_examples=40, deadline=None)
@given(MOVES)
def test_positions_are_the_sum_of_the_moves(tmp_path_factory: pytest.TempPathFactory,
                                            moves: list[tuple[str, int]]) -> None:
    tmp_path = tmp_path_factory.mktemp("moves")
    text = "TX=3\n" + "".join(f"{name} {value}\n" for name, value in moves) + "DN\n"
    expected = {"X": 0, "Y": 0, "Z": 0, "U": 0}
    for name, value in moves:
        axis = {"MR": "X", "T1MR": "Y", "T2MA": "Z", "XMR": "U"}[name]
        expected[axis] = value if name == "T2MA" else expected[axis] + value
    outcome = run_text(tmp_path, text, sample_period=None)
    assert outcome.finished
    report = outcome.to_json()["axes"]
    assert isinstance(report, dict)
    assert {name: value["lp"] for name, value in report.items()} == expected


@settings(max_examples=40, deadline=None)
@given(st.integers(-20, 20), st.integers(-20, 20), st.sampled_from(["JE", "JNE", "JG", "JNG"]))
def test_compare_jumps(tmp_path_factory: pytest.TempPathFactory, c: int, value: int,
                       jump: str) -> None:
    tmp_path = tmp_path_factory.mktemp("jumps")
    text = f"N1={value}\n{jump} {c},N1,$YES\nN2=1\nRET\n$YES\nN2=2\n"
    holds = {"JE": value == c, "JNE": value != c, "JG": value > c, "JNG": value <= c}[jump]
    outcome = run_text(tmp_path, text, sample_period=None)
    assert outcome.machine.n[2] == (2 if holds else 1)
