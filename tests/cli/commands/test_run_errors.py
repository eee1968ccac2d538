"""Run-time findings in the user's terms (issue 14 items 1 and 2): every way a run fails, and
every axis stop, at the source line of the frame that raised it, also inside `std:` and
INCLUDEd files, with the call chain as notes and a stable R-code with a docs page; run results
by declared name. The execution errors are those of registers 115-119 (ET 18744-18773)."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_OK, EXIT_RUN_FAILED, main
from mplang.cli.runwatch import EXIT_OUT_OF_TIME
from mplang.lang.runtime_rules import RUNTIME_RULES
from mplang.m8194h.compiler import compile_paths
from mplang.m8194h.run import RunReport, run_build
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import preload

ROOT = Path(__file__).resolve().parents[3]
JSON_ERROR_KEYS = {"code", "message", "file", "line", "column", "slot", "slot_line", "time_ms",
                   "called_from"}


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / ".git").mkdir()  # the project root, for INCLUDE checks
    return tmp_path


def stdlib_example(heading: str) -> str:
    """The first ```mp block of docs/stdlib.md after `heading`."""
    text = (ROOT / "docs" / "stdlib.md").read_text()
    after = text[text.index(heading):]
    return after.split("```mp\n", 1)[1].split("```", 1)[0]


def line_of(path: Path, needle: str) -> int:
    """The 1-based number of the first line of `path` that contains `needle`."""
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


# ------------------------------------------------------- execution errors (registers 115-119)
def test_115_119_division_by_zero_is_reported_at_its_source_line(project: Path) -> None:
    source = project / "div.mp"
    source.write_text("MP 7 divide\n    VAR1 = 0\n    VAR2 = 10 / VAR1\n    VAR3 = 1\nEND MP\n")
    code, out, err = run("run", source)
    assert code == EXIT_RUN_FAILED and out.startswith("MP7: FAILED")
    assert err.startswith(f"{source}:3:")
    assert "error[R103]: division by zero in VAR_CALCULATE in MP7 divide, slot line" in err
    code, out, _ = run("run", source, "--json")
    error = json.loads(out)["error"]
    assert set(error) == JSON_ERROR_KEYS
    assert (error["code"], error["file"], error["line"], error["slot"]) == \
        ("R103", str(source), 3, "MP7")
    assert error["column"] >= 5 and error["called_from"] == []
    assert error["time_ms"] == json.loads(out)["time_ms"]


def test_115_119_the_slot_line_is_the_one_the_device_records(project: Path) -> None:
    source = project / "div.mp"
    source.write_text("MP 7\n    VAR1 = 0\n    VAR2 = 10 / VAR1\nEND MP\n")
    report = run_build(compile_paths([source]))
    error = report.to_json()["error"]
    assert isinstance(error, dict)
    mp_no, _isr, _cmd, line_no, kind = report.controller.execution_error
    assert (mp_no, kind) == (7, 0x03) and error["slot_line"] == line_no


def test_an_error_inside_an_included_file_names_that_file_and_the_call(project: Path) -> None:
    lib = project / "lib.mp"
    lib.write_text("MP 20 divider\n    VAR5 = 100 / VAR6\nEND MP\n")
    main_mp = project / "tour.mp"
    main_mp.write_text('INCLUDE "lib.mp"\n\nMP 10 tour\n    VAR6 = 0\n    CALL divider\n'
                       "END MP\n")
    code, _, err = run("run", main_mp)
    lines = err.splitlines()
    at = next(n for n, line in enumerate(lines) if "error[R103]" in line)
    assert code == EXIT_RUN_FAILED
    assert re.match(rf"{re.escape(str(lib))}:2:\d+: error\[R103\]: division by zero", lines[at])
    assert lines[at + 1] == f"{main_mp}:5:5: note: called from {main_mp}:5 (MP10 tour)"
    _, out, _ = run("run", main_mp, "--json")
    error = json.loads(out)["error"]
    assert (error["file"], error["line"], error["slot"]) == (str(lib), 2, "MP20")
    assert error["called_from"] == [{"file": str(main_mp), "line": 5, "column": 5,
                                     "program": "MP10 tour", "via": "call"}]


def _chain_tables(vc: VirtualController, depth: int, last: list[list[int]]) -> None:
    """MP1 calls MP2 ... calls MPdepth, whose body is `last` (hand-made frames: the compiler
    refuses such programs itself, E433)."""
    for n in range(1, depth + 1):
        body = [[0x0CCB, n + 1]] if n < depth else last
        assert vc.load_frames("mp", n, [[0x0AC9, n], *body, [0x0CCA]]) is None


def test_115_119_call_depth_is_r101_with_the_whole_chain() -> None:
    vc = VirtualController()
    _chain_tables(vc, 9, [[0x0CDD]])
    vc.call(1)
    failure = vc.run().failure
    assert failure is not None and failure.code == "R101" and failure.place is not None
    assert failure.place.slot == vc.execution_error[0] == 7
    assert [caller.slot for caller in failure.callers] == [6, 5, 4, 3, 2, 1]


def test_115_119_a_call_of_an_empty_slot_is_r102() -> None:
    vc = VirtualController()
    _chain_tables(vc, 2, [[0x0CCB, 40]])  # MP2 calls MP40, which was never downloaded
    vc.call(1)
    failure = vc.run().failure
    assert failure is not None and failure.code == "R102"
    assert failure.place is not None and failure.place.slot == 2
    assert [caller.slot for caller in failure.callers] == [1]


# ------------------------------------------------------- runs that do not end
def test_the_stdlib_homing_example_waits_for_ever_in_std_home_limit(project: Path) -> None:
    source = project / "home.mp"
    source.write_text(stdlib_example("### `std:home_limit.mp`"))
    code, out, err = run("run", source, "--max-time", "5")
    call_line = line_of(source, "CALL std_home_limit")
    first, note = err.splitlines()[:2]
    found = re.match(r"std:home_limit\.mp:(\d+):(\d+): error\[R201\]: ", first)
    assert code == EXIT_RUN_FAILED and found is not None
    library = (ROOT / "stdlib" / "home_limit.mp").read_text().splitlines()
    assert library[int(found.group(1)) - 1].strip().startswith("STOP_WAIT")
    assert "error[R201]: STOP_WAIT waits for ever in MP131 std_home_limit" in first
    assert note.startswith(f"{source}:{call_line}:5: note: called from {source}:{call_line}")
    assert "std_home_limit_axes (VAR400) = 4" in out


def test_a_run_out_of_time_is_r202_at_the_line_it_was_at(project: Path) -> None:
    source = project / "spin.mp"
    source.write_text("MP 3 spin\n    VAR1 = 0\n    LABEL again\n    VAR1 = VAR1 + 1\n"
                      "    GOTO again\nEND MP\n")
    code, out, _ = run("run", source, "--json", "--max-time", "0.05")
    error = json.loads(out)["error"]
    assert code == EXIT_OUT_OF_TIME and error["code"] == "R202"  # 18 since issue 14 item 4
    assert error["file"] == str(source) and 3 <= error["line"] <= 5


# ------------------------------------------------------- axis stops and unmodelled commands
def test_a_failed_home_search_warns_at_the_library_line_and_the_run_finishes(
        project: Path) -> None:
    source = project / "index.mp"
    source.write_text(stdlib_example("### `std:home_index.mp`"))
    code, out, err = run("run", source)
    start_line = line_of(ROOT / "stdlib" / "home_index.mp", "HOME_START U")
    assert code == EXIT_OK and "std_home_index_error (VAR401) = 128" in out
    first, note = err.splitlines()[:2]
    assert first.startswith(f"std:home_index.mp:{start_line}:")
    assert "warning[R315]: axis U stopped on a failed home search" in first
    assert note.startswith(f"{source}:") and "note: called from" in note


def test_3_9_1_a_software_limit_stop_warns_at_the_line_that_waited(project: Path) -> None:
    source = project / "slmt.mp"
    source.write_text("MP 4\n    SET_V X, 10000\n    SET_SLMT X, 1000, -1000, 0\n"
                      "    FIXED_MOVE X, 5000\n    STOP_WAIT X\n    VAR1 = 1\nEND MP\n")
    code, out, err = run("run", source)
    assert code == EXIT_OK and "  VAR1 = 1\n" in out
    assert err == (f"{source}:5:5: warning[R312]: axis X stopped on the software limit in MP4, "
                   "slot line 3\n")


def test_the_trace_follows_the_source_line_and_ends_at_the_failing_one(project: Path) -> None:
    """`--trace`: the `source` column is the line the running program is at, in the file it
    is in (an INCLUDEd one too), empty once no program runs; a failed run's last sample is
    at the failing line."""
    (project / "share.mp").write_text("MP 31 share\n    result = 10 / zero\nEND MP\n")
    source = project / "divide.mp"
    source.write_text('VAR zero\nVAR result\nINCLUDE "share.mp"\n\nMP 30 divide\n'
                      "    FIXED_MOVE X, 1000\n    STOP_WAIT X\n    zero = 0\n"
                      "    CALL share\nEND MP\n")
    trace_file = project / "divide.csv"
    code, _out, _err = run("run", source, "--trace", trace_file)
    assert code == EXIT_RUN_FAILED
    rows = list(csv.reader(trace_file.open()))
    places = [row[rows[0].index("source")] for row in rows[1:]]
    assert places[0] == f"{source}:6" and f"{source}:7" in places  # FIXED_MOVE, STOP_WAIT
    assert places[-1] == f"{project / 'share.mp'}:2"  # the division by zero
    clean = project / "clean.mp"
    clean.write_text("MP 5\n    FIXED_MOVE X, 100\nEND MP\n")
    code, _out, _err = run("run", clean, "--trace", trace_file)
    rows = list(csv.reader(trace_file.open()))
    assert code == EXIT_OK and rows[-1][-1] == ""  # the move runs on after the program ended


def test_json_lists_the_warnings_as_error_objects(project: Path) -> None:
    """The axis stops (R311-R315) and unmodelled commands (R301) that text output prints
    on standard error are in `--json` too, each as the "error" object, at its source line;
    a run without any has no "warnings" key."""
    source = project / "slmt.mp"
    source.write_text("MP 4\n    SET_V X, 10000\n    SET_SLMT X, 1000, -1000, 0\n"
                      "    FIXED_MOVE X, 5000\n    STOP_WAIT X\n    VAR1 = 1\nEND MP\n")
    code, out, _err = run("run", "--json", source)
    summary = json.loads(out)
    assert code == EXIT_OK and summary["error"] is None
    (stop,) = summary["warnings"]
    assert (stop["code"], stop["file"], stop["line"], stop["column"], stop["slot"],
            stop["slot_line"]) == ("R312", str(source), 5, 5, "MP4", 3)
    assert stop["message"] == "axis X stopped on the software limit"
    clean = project / "clean.mp"
    clean.write_text("MP 5\n    VAR1 = 1\nEND MP\n")
    code, out, _err = run("run", "--json", clean)
    assert code == EXIT_OK and "warnings" not in json.loads(out)


# ------------------------------------------------------- the other families
def test_fatek_and_csim_errors_have_the_same_object(project: Path) -> None:
    listing = project / "stuck.csim"
    listing.write_text("N1=0\nWI 1\n")
    code, out, err = run("run", listing, "--json", "--max-time", "5")
    error = json.loads(out)["error"]
    assert code == EXIT_RUN_FAILED and set(error) == JSON_ERROR_KEYS
    assert (error["code"], error["file"], error["line"], error["slot_line"]) == \
        ("R201", str(listing), 2, 1)
    code, _, err = run("run", listing, "--max-time", "5")
    assert err.startswith(f"{listing}:2:1: error[R201]: 'WI 1' waits for ever")
    code, out, _ = run("run", ROOT / "samples" / "fatek" / "drvc_three_speeds.fbs", "--json")
    error = json.loads(out)["error"]
    assert set(error) == JSON_ERROR_KEYS and error["code"] == "R201"
    assert (error["slot"], error["slot_line"], error["line"]) == ("drvc_three_speeds", 3, 13)


# ------------------------------------------------------- names (issue 14 item 2)
def test_results_show_declared_names_with_their_device_number(project: Path) -> None:
    source = project / "rows.mp"
    source.write_text("VAR rows_done\nVAR untouched\nALIAS hits = VAR30\n\nMP 1 rows\n"
                      "    rows_done = 4\n    hits = 2\n    VAR7 = 9\nEND MP\n")
    code, out, _ = run("run", source)
    assert code == EXIT_OK
    numbers = json.loads(run("run", source, "--json")[1])["names"]
    assert numbers["hits"] == "VAR30" and set(numbers) == {"rows_done", "untouched", "hits"}
    assert f"  rows_done ({numbers['rows_done']}) = 4\n" in out
    assert f"  untouched ({numbers['untouched']}) = 0\n" in out  # declared: shown though 0
    assert "  hits (VAR30) = 2\n" in out and "  VAR7 = 9\n" in out
    summary = json.loads(run("run", source, "--json")[1])
    assert summary["vars"] == {"hits": 2, "rows_done": 4, "untouched": 0, "VAR7": 9}
    assert list(summary["vars"])[-1] == "VAR7"  # the declared names first
    assert summary["error"] is None


# ------------------------------------------------------- the codes and their pages
def test_every_runtime_code_has_its_docs_page() -> None:
    index = (ROOT / "docs" / "runtime" / "README.md").read_text()
    for code, rule in RUNTIME_RULES.items():
        page = ROOT / "docs" / "runtime" / f"{code}.md"
        assert page.read_text().startswith(f"# {code} `{rule.name}`")
        assert f"[{code}]({code}.md)" in index
    assert not set(RUNTIME_RULES) & {p.stem for p in (ROOT / "docs" / "checks").glob("*.md")}


def test_mpc_plot_reports_the_failure_at_its_source_line(project: Path) -> None:
    source = project / "div.mp"
    source.write_text("MP 7 divide\n    VAR1 = 0\n    VAR2 = 10 / VAR1\nEND MP\n")
    code, out, err = run("plot", source, "-o", project / "div.svg", "--width", "300",
                         "--height", "300")
    assert code == EXIT_RUN_FAILED and (project / "div.svg").exists()
    assert out.startswith("MP7: FAILED")
    assert err.startswith(f"{source}:3:") and "error[R103]: division by zero" in err


def test_an_error_in_an_isr_notes_the_line_it_interrupted(project: Path) -> None:
    source = project / "isr.mp"
    source.write_text("MP 1 main\n    VAR1 = 0\n    TIMER 100\nEND MP\n"
                      "ISR 2 bad\n    VAR2 = 1 / VAR1\nEND ISR\n")
    build = compile_paths([source])
    vc = VirtualController(word_order=build.word_order)
    preload(vc, build)
    vc.call(1)
    vc.advance(0.01)  # MP1 waits in its TIMER
    vc.request_isr(2)
    report = RunReport(vc, vc.run(), "MP1", build=build)
    failure = report.failure
    assert failure is not None and failure.code == "R103"
    assert (failure.where.file, failure.where.line, failure.slot) == (str(source), 6, "ISR2")
    assert failure.render().splitlines()[1] == \
        f"{source}:3:5: note: interrupted at {source}:3 (MP1 main)"
