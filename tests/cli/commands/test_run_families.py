"""`mpc run` for the FATEK and CSIM families: every listing of the manuals runs through the
CLI as through the library, one `.mp` job ends in the same place on every controller, and
--call, --max-time, --json and --trace behave as for the M8194H."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang import csim, fatek
from mplang.cli import EXIT_OK, EXIT_RUN_FAILED, EXIT_SOURCE_ERRORS, EXIT_USAGE, main
from mplang.cli.runwatch import EXIT_OUT_OF_TIME

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"
FBS = sorted((SAMPLES / "fatek").glob("*.fbs"))
CSIM = sorted((SAMPLES / "csim").glob("*.csim"))
INDEXER = SAMPLES / "families" / "indexer.mp"
MAX_TIME = "120"  # the cyclic examples wait for an operator or jog until stopped


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


@pytest.mark.parametrize("listing", FBS, ids=[p.name for p in FBS])
def test_every_fatek_listing_runs_as_the_library_runs_it(listing: Path) -> None:
    expected = fatek.run_build(fatek.check_native([listing]), None, float(MAX_TIME))
    code, out, err = run("run", listing, "--json", "--max-time", MAX_TIME)
    assert json.loads(out) == json.loads(json.dumps(expected.to_json()))
    failure = expected.failure
    assert code == (EXIT_OK if expected.finished else EXIT_OUT_OF_TIME
                    if failure is not None and failure.code == "R202" else EXIT_RUN_FAILED)
    assert err == ""


@pytest.mark.parametrize("listing", CSIM, ids=[p.name for p in CSIM])
def test_every_csim_listing_runs_and_finishes(listing: Path) -> None:
    expected = csim.run_build(csim.check_native([listing]), None, float(MAX_TIME))
    code, out, err = run("run", listing, "--json", "--max-time", MAX_TIME)
    assert (code, err) == (EXIT_OK, "")
    assert json.loads(out) == json.loads(json.dumps(expected.to_json()))
    assert set(json.loads(out)) == {"called", "vars", "names", "axes", "time_ms", "error"}


@pytest.mark.parametrize(("name", "x"), [("format_example.fbs", 5000),
                                         ("drvc_three_speeds.fbs", 85000),
                                         ("jog_forward.fbs", 1_000_000)])
def test_the_manual_examples_end_where_the_manual_says(name: str, x: int) -> None:
    _, out, _ = run("run", SAMPLES / "fatek" / name, "--json", "--max-time", MAX_TIME)
    assert json.loads(out)["axes"]["X"] == {"lp": x, "ep": x}


@pytest.mark.parametrize("target", ["et", "rs", "fbs-fun140", "fbs-fun147", "csim"])
def test_one_mp_job_ends_at_the_same_place_on_every_controller(target: str) -> None:
    code, out, _ = run("run", INDEXER, "--target", target, "--json")
    summary = json.loads(out)
    assert code == EXIT_OK and summary["error"] is None
    positions = {name: axis["lp"] for name, axis in summary["axes"].items()}
    assert positions == {"X": 16250, "Y": 0, "Z": 0, "U": 0}
    assert summary["called"] in ("MP95", "indexer")


@pytest.mark.parametrize(("source", "targets"), [
    (SAMPLES / "fatek" / "feeder.mp", ["et", "fbs-fun140", "fbs-fun147", "csim"]),
    (SAMPLES / "fatek" / "gantry.mp", ["et", "fbs-fun147", "csim"]),
    (SAMPLES / "csim" / "cross_target.mp", ["et", "csim"]),
])
def test_the_cross_target_samples_agree(source: Path, targets: list[str]) -> None:
    ends = []
    for target in targets:
        code, out, _ = run("run", source, "--target", target, "--json")
        assert code == EXIT_OK, (target, out)
        ends.append({name: axis["lp"] for name, axis in json.loads(out)["axes"].items()})
    assert all(end == ends[0] for end in ends)


def test_the_m8194h_summary_names_the_program_called() -> None:
    code, out, _ = run("run", INDEXER, "--json")
    summary = json.loads(out)
    assert code == EXIT_OK and summary["called"] == "MP95"
    assert list(summary) == ["called", "vars", "names", "axes", "time_ms", "error"]


def test_text_summary_and_a_run_that_does_not_finish() -> None:
    code, out, err = run("run", SAMPLES / "fatek" / "drvc_three_speeds.fbs")
    assert code == EXIT_RUN_FAILED
    assert out.startswith("drvc_three_speeds: FAILED after 5348.322 ms simulated on the "
                          "virtual FATEK FBs-PLC\n")
    assert "  X: lp 85000, ep 85000\n" in out
    assert err == ("samples/fatek/drvc_three_speeds.fbs:13:1: error[R201]: step 3 waits for X0, "
                   "which never turns ON (no SIM line drives it) in drvc_three_speeds, step 3\n")


def test_max_time_stops_a_jog() -> None:
    code, out, _ = run("run", SAMPLES / "fatek" / "example4_jog_forward.fbs", "--json",
                       "--max-time", "2")
    summary = json.loads(out)
    assert code == EXIT_OUT_OF_TIME and summary["time_ms"] == 2000.0
    assert "stopped after 2 s of simulated time" in summary["error"]["message"]
    assert summary["error"]["code"] == "R202"


@pytest.mark.parametrize(("args", "called"), [
    (("--call", "feeder"), "feeder"), (("--call", "MP91"), "feeder"),
    (("--call", "feeder:3"), "feeder:3"),
])
def test_call_picks_a_fatek_table_and_step(args: tuple[str, ...], called: str) -> None:
    code, out, _ = run("run", SAMPLES / "fatek" / "feeder.mp", "--target", "fbs-fun140",
                       "--json", *args)
    assert code == EXIT_OK and json.loads(out)["called"] == called


def test_call_picks_a_csim_entry() -> None:
    source = SAMPLES / "csim" / "cross_target.mp"
    code, out, _ = run("run", source, "--target", "csim", "--call", "park_y", "--json")
    assert code == EXIT_OK and json.loads(out)["called"] == "cross_target:$PARK_Y"


@pytest.mark.parametrize(("source", "target", "call", "message"), [
    (SAMPLES / "fatek" / "feeder.mp", "fbs-fun140", "nothing", "no table named 'nothing'"),
    (SAMPLES / "fatek" / "feeder.mp", "fbs-fun140", "fun141_ps0", "FUN141 parameter table"),
    (SAMPLES / "fatek" / "feeder.mp", "fbs-fun140", "feeder:99", "has steps 1-8, not 99"),
    (INDEXER, "csim", "$NOWHERE", "names no program, entry or label"),
])
def test_an_unknown_call_is_a_usage_error(source: Path, target: str, call: str,
                                          message: str) -> None:
    code, out, err = run("run", source, "--target", target, "--call", call)
    assert (code, out) == (EXIT_USAGE, "")
    assert "--call" in err and message in err


def test_a_build_with_errors_exits_1_before_running() -> None:
    code, out, err = run("run", SAMPLES / "fatek" / "gantry.mp", "--target", "fbs-fun140")
    assert (code, out) == (EXIT_SOURCE_ERRORS, "") and "error[E643]" in err


def read_trace(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as stream:
        return list(csv.DictReader(stream))


def test_trace_of_a_fatek_run_has_the_m8194h_columns(tmp_path: Path) -> None:
    trace_file = tmp_path / "feeder.csv"
    code, out, _ = run("run", SAMPLES / "fatek" / "feeder.mp", "--target", "fbs-fun140",
                       "--trace", trace_file)
    assert code == EXIT_OK
    rows = read_trace(trace_file)
    assert list(rows[0]) == ["time_s"] + [f"{axis}_{column}" for axis in "XYZU"
                                          for column in ("lp", "ep", "velocity")]
    assert f"trace: {len(rows)} samples written to {trace_file}" in out
    assert all(row["X_lp"] == row["X_ep"] for row in rows)
    assert max(int(row["X_lp"]) for row in rows) == 21500
    assert max(float(row["X_velocity"]) for row in rows) == pytest.approx(20000, rel=0.02)
    assert rows[-1]["X_lp"] == "0" and float(rows[-1]["time_s"]) == pytest.approx(4.152135)


def test_trace_of_a_csim_run_keeps_real_coordinates(tmp_path: Path) -> None:
    trace_file = tmp_path / "arc.csv"
    code, _, _ = run("run", SAMPLES / "csim" / "arc_360.csim", "--trace", trace_file,
                     "--trace-period", "0.01")
    assert code == EXIT_OK
    rows = read_trace(trace_file)
    times = [float(row["time_s"]) for row in rows]
    assert times == sorted(set(times))
    assert any("." in row["X_lp"] for row in rows)  # arcs pass between whole units
    assert len(rows) < 200  # every 10 ms, not every 1 ms


def test_trace_of_a_failed_run_is_still_written(tmp_path: Path) -> None:
    trace_file = tmp_path / "drvc.csv"
    code, _, _ = run("run", SAMPLES / "fatek" / "drvc_three_speeds.fbs", "--trace", trace_file)
    assert code == EXIT_RUN_FAILED
    assert read_trace(trace_file)[-1]["X_lp"] == "85000"


def test_trace_place_is_checked_before_the_run(tmp_path: Path) -> None:
    code, _, err = run("run", SAMPLES / "csim" / "helix.csim", "--trace",
                       tmp_path / "no" / "t.csv")
    assert code == 4 and "no directory" in err
