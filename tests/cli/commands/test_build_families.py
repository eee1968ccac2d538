"""`mpc build` for the FATEK and CSIM families: which family a build is for (suffixes,
--target, mpc.toml), their formats, and every refusal with its exit code."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang import csim, fatek
from mplang.cli import EXIT_NO_INPUT, EXIT_OK, EXIT_SOURCE_ERRORS, EXIT_USAGE, main
from mplang.m8194h.compiler import Options

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"
DRVC = SAMPLES / "fatek" / "drvc_three_speeds.fbs"
FEEDER = SAMPLES / "fatek" / "feeder.mp"
TWO_AXIS = SAMPLES / "csim" / "two_axis_2ma.csim"
INDEXER = SAMPLES / "families" / "indexer.mp"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


def test_a_fbs_listing_builds_to_its_native_listing_by_default() -> None:
    code, out, err = run("build", DRVC)
    assert (code, err) == (EXIT_OK, "")
    assert out == fatek.check_native([DRVC]).render("fbs")
    assert "TABLE drvc_three_speeds FUN140 Ps0" in out


@pytest.mark.parametrize("fmt", ["fbs", "listing", "table", "json"])
def test_every_fatek_format_is_the_library_rendering(fmt: str) -> None:
    code, out, _ = run("build", DRVC, "--format", fmt)
    assert code == EXIT_OK
    assert out == fatek.check_native([DRVC]).render(fmt)


def test_the_register_table_of_an_mp_source_for_fun140() -> None:
    code, out, _ = run("build", FEEDER, "--target", "fbs-fun140", "--format", "table")
    assert code == EXIT_OK
    assert "A55AH  flag: a valid FUN140 program" in out
    assert out == fatek.compile_mp([FEEDER], Options(), "fbs-fun140").render("table")


def test_fun147_target_writes_fun147_tables() -> None:
    code, out, _ = run("build", FEEDER, "--target", "fbs-fun147", "--format", "json")
    assert code == EXIT_OK
    tables = json.loads(out)["tables"]
    assert json.loads(out)["target"]["variant"] == "fbs-fun147"
    assert [t["kind"] for t in tables] == ["fun147", "fun141"]


@pytest.mark.parametrize(("fmt", "expected"), [(None, "csim"), ("csim", "csim"),
                                               ("listing", "listing"), ("json", "json")])
def test_csim_formats(fmt: str | None, expected: str) -> None:
    args = ["build", str(TWO_AXIS)] + ([] if fmt is None else ["--format", fmt])
    code, out, _ = run(*args)
    assert code == EXIT_OK
    assert out == csim.check_native([TWO_AXIS]).render(expected)


def test_mp_for_csim_writes_the_script_with_its_warnings_on_stderr(tmp_path: Path) -> None:
    out_file = tmp_path / "indexer.csim"
    code, out, err = run("build", INDEXER, "--target", "csim", "-o", out_file)
    assert (code, out) == (EXIT_OK, "")
    assert "warning[W701]" in err  # the counter's arithmetic
    text = out_file.read_text()
    assert text == csim.compile_mp([INDEXER], Options(), "csim").render("csim")
    assert "$INDEXER" in text and "XMR 3000" in text


def test_the_written_script_builds_again_as_a_native_listing(tmp_path: Path) -> None:
    out_file = tmp_path / "indexer.csim"
    assert run("build", INDEXER, "--target", "csim", "-o", out_file)[0] == EXIT_OK
    code, out, _ = run("build", out_file, "--format", "csim")
    assert code == EXIT_OK
    assert [line for line in out.splitlines() if not line.startswith("#")] == \
        [line for line in out_file.read_text().splitlines() if not line.startswith("#")]


def test_errors_in_a_listing_exit_1_with_file_line_col(tmp_path: Path) -> None:
    bad = tmp_path / "bad.fbs"
    bad.write_text("001 SPD 0\n    DRV ADR,+,100,Ps\n    MEND\n")
    code, out, err = run("build", bad)
    assert (code, out) == (EXIT_SOURCE_ERRORS, "")
    assert f"{bad}:1:9: error[E604]" in err and err.endswith("\n1 error, 0 warnings in 1 file\n")


def test_mp_lines_a_family_cannot_express_exit_1_at_the_mp_line() -> None:
    code, _, err = run("build", SAMPLES / "fatek" / "gantry.mp", "--target", "fbs-fun140")
    assert code == EXIT_SOURCE_ERRORS
    assert "gantry.mp:20:9: error[E643]" in err and "--target fbs-fun147" in err


def test_target_narrows_a_fatek_listing(tmp_path: Path) -> None:
    code, _, err = run("build", DRVC, "--target", "fbs-fun147")
    assert code == EXIT_SOURCE_ERRORS
    assert "error[E616]" in err and "FUN140 table, but the target is fbs-fun147" in err
    assert run("build", DRVC, "--target", "fbs-fun140")[0] == EXIT_OK


def test_a_missing_listing_exits_3() -> None:
    code, _, err = run("build", "nowhere.fbs")
    assert code == EXIT_NO_INPUT and "nowhere.fbs: no such file" in err


def test_an_unreadable_listing_is_a_diagnostic(tmp_path: Path) -> None:
    broken = tmp_path / "latin1.csim"
    broken.write_bytes(b"OUT \"\xe9\"\n")
    code, _, err = run("build", broken)
    assert code == EXIT_SOURCE_ERRORS and str(broken) in err


@pytest.mark.parametrize(("args", "words"), [
    ((DRVC, TWO_AXIS), ["several", "FATEK FBs-PLC: ", "drvc_three_speeds.fbs",
                        "CSIM: ", "two_axis_2ma.csim"]),
    ((DRVC, FEEDER), ["FATEK FBs-PLC listings and .mp sources do not build together",
                      "drvc_three_speeds.fbs", "feeder.mp", "--target fbs-fun140"]),
    ((TWO_AXIS, "--target", "fbs-fun140"), ["two_axis_2ma.csim: CSIM source(s), but the "
                                            "target is fbs-fun140", "--target csim"]),
    ((DRVC, "--target", "et"), ["target is et", "use --target fbs-fun140 or fbs-fun147"]),
    ((DRVC, "--format", "hex"), ["--format hex is not a format of FATEK FBs-PLC builds",
                                 "fbs, listing, table, json"]),
    ((TWO_AXIS, "--format", "table"), ["--format table is not a format of CSIM builds",
                                       "listing, json, csim (default csim)"]),
    ((FEEDER, "--format", "table"), ["it is for FATEK FBs-PLC builds",
                                     "use json, listing, hex, map"]),
    ((FEEDER, "--format", "csim"), ["it is for CSIM builds"]),
    ((FEEDER, "--target", "csim", "--word-order", "1"), ["--word-order: M8194H option",
                                                         "CSIM builds have no such"]),
    ((FEEDER, "--target", "fbs"), ["'fbs' is not one of", "'fbs-fun140'", "'csim'"]),
])
def test_refusals_are_usage_errors_naming_the_files(args: tuple[str | Path, ...],
                                                    words: list[str]) -> None:
    code, out, err = run("build", *args)
    assert (code, out) == (EXIT_USAGE, "")
    flat = " ".join(err.split())
    for word in words:
        assert word in flat, (word, err)


def test_the_m8194h_build_is_unchanged() -> None:
    code, out, err = run("build", SAMPLES / "tour.mp")
    assert (code, err) == (EXIT_OK, "")
    assert json.loads(out)["format"] == "mplang-image/1"
    assert "\nMP95     0: 0AC9 005F\n" in run("build", INDEXER, "--target", "rs", "--format",
                                                 "hex")[1]


def test_a_project_file_with_a_family_target(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                             ) -> None:
    (tmp_path / "indexer.mp").write_text(INDEXER.read_text())
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["indexer.mp"]\ntarget = "csim"\n'
                                       "word-order = 1\n[slots]\nback_off = \"MP3\"\n")
    monkeypatch.chdir(tmp_path)
    code, out, err = run("build")
    assert code == EXIT_OK and "$INDEXER" in out
    assert "[slots] pins place M8194H programs" in err and "word-order is an M8194H" in err
    assert run("build", "--target", "et")[1].startswith("{")  # the command line wins
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["indexer.mp"]\n'
                                       'target = "fbs-fun140"\n')
    code, out, _ = run("build", "--format", "table")
    assert code == EXIT_OK and "FUN140 table 'indexer'" in out


def test_help_lists_every_family_target_and_format() -> None:
    code, out, _ = run("build", "--help")
    flat = " ".join(out.split())
    assert code == EXIT_OK
    assert "[et|rs|fbs-fun140|fbs-fun147|csim]" in flat
    assert "vars-py|triggers|fbs|table|csim]" in flat


def test_mpc_help_and_m8194h_builds_do_not_import_the_families() -> None:
    probe = ("import sys\nfrom click.testing import CliRunner\nfrom mplang.cli import main\n"
             "for args in (['--help'], ['build', 'samples/tour.mp', '-o', '/dev/null']):\n"
             "    assert CliRunner().invoke(main, args).exit_code == 0\n"
             "print(sorted(m for m in sys.modules if m in ('mplang.fatek', 'mplang.csim')))\n")
    done = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True,
                          text=True, check=True)
    assert done.stdout.strip() == "[]"
