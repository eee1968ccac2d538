"""`mpc build` / `mpc lint` as a user runs them: exit codes, streams and formats."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sarifcheck import validated

from mplang.cli import main

GOOD = "CONST V = 2000\nMP 21 square\n  SET_V X, V\n  FIXED_MOVE X, 1000\nEND MP\n"
BAD = "MP 1\n  FIXD_MOVE X, 1\n  FIXED_MOVE Q, 1\nEND MP\n"


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / ".git").mkdir()  # marks the project root for INCLUDE checks
    (tmp_path / "good.mp").write_text(GOOD)
    (tmp_path / "bad.mp").write_text(BAD)
    return tmp_path


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_build_json_to_stdout(project: Path) -> None:
    code, out, err = run("build", str(project / "good.mp"))
    assert code == 0 and err == ""
    image = json.loads(out)
    assert image["format"] == "mplang-image/1"
    assert image["target"]["word_order"] == 0
    (program,) = image["programs"]
    assert (program["kind"], program["slot"], program["name"]) == ("mp", 21, "square")
    assert (program["lines_used"], program["budget"]) == (3, 8)
    assert program["frames"] == [[2761, 21], [3144, 1, 0, 2000], [3150, 1, 0, 1000], [3274]]


def test_build_word_order_1_and_output_file(project: Path) -> None:
    out_file = project / "image.json"
    code, out, _ = run("build", str(project / "good.mp"), "--word-order", "1", "-o",
                       str(out_file))
    assert code == 0 and out == ""
    frames = json.loads(out_file.read_text())["programs"][0]["frames"]
    assert frames[1] == [3144, 1, 2000, 0]


def test_build_errors_go_to_stderr_with_exit_1(project: Path) -> None:
    code, out, err = run("build", str(project / "bad.mp"))
    assert code == 1 and out == ""
    assert "bad.mp:2:3: error[E201]: unknown command 'FIXD_MOVE'" in err
    assert "did you mean FIXED_MOVE?" in err
    assert "bad.mp:3:14: error[E202]" in err


def test_missing_file_exit_3(project: Path) -> None:
    code, _, err = run("build", str(project / "nope.mp"))
    assert code == 3 and "no such file" in err
    code, _, err = run("lint", str(project / "*.xyz"))
    assert code == 3 and "no files match" in err


def test_unwritable_output_exit_4(project: Path) -> None:
    code, _, err = run("build", str(project / "good.mp"), "-o", str(project / "no" / "x.json"))
    assert code == 4 and "cannot write" in err


def test_usage_error_exit_2() -> None:
    assert run("build")[0] == 2
    assert run("build", "x.mp", "--format", "pdf")[0] == 2
    assert run("build", "x.mp", "--temp-vars", "600-700")[0] == 2


def test_globs_and_directories(project: Path) -> None:
    (project / "bad.mp").unlink()
    (project / "sub").mkdir()
    (project / "sub" / "more.mp").write_text("MP helper\n  EXIT\nEND MP\n")
    code, out, _ = run("build", str(project), "--format", "map")
    assert code == 0 and "MP21" in out and "helper" in out
    code, out, _ = run("build", str(project / "**" / "*.mp"), "--format", "hex")
    assert code == 0 and "0AC9 0015" in out


def test_listing_shows_source_slot_lines_cost_and_frames(project: Path) -> None:
    code, out, _ = run("build", str(project / "good.mp"), "--format", "listing")
    assert code == 0
    assert "MP21 square" in out and "3/8 lines" in out
    line = next(row for row in out.splitlines() if "FIXED_MOVE X, 1000" in row)
    assert "good.mp:4" in line and "0C4E 0001 0000 03E8" in line


def test_lint_text_json_sarif(project: Path) -> None:
    code, out, _ = run("lint", str(project / "bad.mp"))
    assert code == 1 and out.splitlines()[0].startswith(str(project / "bad.mp") + ":2:3: error[")
    code, out, _ = run("lint", str(project / "bad.mp"), "--format", "json")
    assert code == 1 and {d["code"] for d in json.loads(out)} == {"E201", "E202"}
    code, out, _ = run("lint", str(project / "bad.mp"), "--format", "sarif")
    sarif = validated(out)
    assert code == 1 and sarif["version"] == "2.1.0"
    results = sarif["runs"][0]["results"]
    rules = sarif["runs"][0]["tool"]["driver"]["rules"]
    assert {r["ruleId"] for r in results} == {r["id"] for r in rules} == {"E201", "E202"}
    region = results[0]["locations"][0]["physicalLocation"]["region"]
    assert region["startLine"] == 2
    assert run("lint", str(project / "good.mp"))[0] == 0


def test_werror_fails_on_warnings(project: Path) -> None:
    (project / "warn.mp").write_text("MP 1\n  VAR2 = VAR1\nEND MP\n")
    assert run("lint", str(project / "warn.mp"))[0] == 0
    assert run("lint", str(project / "warn.mp"), "--werror")[0] == 1


def test_help_everywhere() -> None:
    for command in ([], ["build"], ["lint"]):
        code, out, _ = run(*command, "--help")
        assert code == 0 and "Usage:" in out


def test_console_script_runs_as_a_process(project: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "mplang", "build", str(project / "bad.mp")],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(max_size=120))
def test_arbitrary_text_never_raises_past_the_cli(tmp_path: Path, text: str) -> None:
    source = tmp_path / "fuzz.mp"
    source.write_text(text, encoding="utf-8")
    for command in (["lint", str(source)], ["build", str(source), "--format", "listing"]):
        result = CliRunner().invoke(main, command)
        assert result.exit_code in (0, 1), result.output
        assert result.exception is None or isinstance(result.exception, SystemExit)


def test_run_json_reports_vars_axes_time_and_error(project: Path) -> None:
    (project / "moves.mp").write_text("MP 21 main\n  SET_V X, 10000\n  FIXED_MOVE X, 5000\n"
                                      "  STOP_WAIT X\n  VAR1 = GET_LP(X)\n  VAR2 = VAR1 / 5\n"
                                      "END MP\n")
    code, out, _ = run("run", str(project / "moves.mp"), "--json")
    assert code == 0
    report = json.loads(out)
    assert report["vars"] == {"VAR1": 5000, "VAR2": 1000}
    assert report["axes"]["X"] == {"lp": 5000, "ep": 5000}
    assert report["axes"]["U"] == {"lp": 0, "ep": 0}
    assert report["error"] is None and report["time_ms"] > 0


def test_run_picks_first_mp_of_first_file_or_call(project: Path) -> None:
    (project / "two.mp").write_text("MP 30 second\n  VAR1 = 2\nEND MP\n"
                                    "MP 5 first_in_file\n  VAR1 = 1\nEND MP\n")
    assert json.loads(run("run", str(project / "two.mp"), "--json")[1])["vars"] == {"VAR1": 2}
    code, out, _ = run("run", str(project / "two.mp"), "--json", "--call", "first_in_file")
    assert code == 0 and json.loads(out)["vars"] == {"VAR1": 1}
    assert run("run", str(project / "two.mp"), "--call", "MP99")[0] == 2


def test_run_that_never_finishes_exits_17(project: Path) -> None:
    """Out of --max-time (R202) has its own exit code since issue 14 item 4 (it was 5)."""
    (project / "spin.mp").write_text("MP 1\n  LABEL a\n  GOTO a\nEND MP\n")
    code, out, _ = run("run", str(project / "spin.mp"), "--json", "--max-time", "1")
    error = json.loads(out)["error"]
    assert code == 18 and error["code"] == "R202" and "--max-time" in error["message"]
    assert (error["file"], error["line"], error["slot"]) == (str(project / "spin.mp"), 2, "MP1")
