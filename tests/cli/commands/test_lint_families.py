"""`mpc lint` for the FATEK and CSIM families: every listing of the manuals lints clean, and
family diagnostics come out in text, JSON and SARIF exactly as M8194H ones do."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from sarifcheck import validated

from mplang import csim, fatek
from mplang.cli import EXIT_NO_INPUT, EXIT_OK, EXIT_SOURCE_ERRORS, EXIT_USAGE, main
from mplang.cli.style import SourceLines, render_diagnostic
from mplang.lang.diagnostics import Diagnostic
from mplang.m8194h.compiler import Options
from mplang.tools.report import (
    render_diagnostics_json,
    render_github,
    render_gitlab,
    render_sarif,
)

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"
LISTINGS = sorted((SAMPLES / "fatek").glob("*.fbs")) + sorted((SAMPLES / "csim").glob("*.csim"))
CHECKS = ROOT / "tests" / "data" / "checks"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


@pytest.mark.parametrize("listing", LISTINGS, ids=[p.name for p in LISTINGS])
def test_every_sample_listing_lints_clean(listing: Path) -> None:
    assert run("lint", listing, "--werror") == (EXIT_OK, "", "")


@pytest.mark.parametrize(("source", "target"), [
    (SAMPLES / "fatek" / "feeder.mp", "fbs-fun140"),
    (SAMPLES / "fatek" / "gantry.mp", "fbs-fun147"),
    (SAMPLES / "families" / "indexer.mp", "fbs-fun140"),
    (SAMPLES / "families" / "indexer.mp", "fbs-fun147"),
])
def test_sample_mp_sources_lint_clean_for_the_plc(source: Path, target: str) -> None:
    assert run("lint", source, "--target", target, "--werror") == (EXIT_OK, "", "")


def test_mp_for_csim_lints_with_its_warnings_and_werror_fails_it() -> None:
    source = SAMPLES / "families" / "indexer.mp"
    code, out, _ = run("lint", source, "--target", "csim")
    assert code == EXIT_OK and "warning[W701]" in out
    assert run("lint", source, "--target", "csim", "--werror")[0] == EXIT_SOURCE_ERRORS


def _text(diagnostics: list[Diagnostic]) -> str:
    """`mpc lint`'s text in a pipe: each diagnostic with its excerpt, no colour."""
    return "".join(render_diagnostic(d, SourceLines(), False) + "\n" for d in diagnostics)


@pytest.mark.parametrize("name", ["E604.fbs", "W601.fbs", "E705.csim", "W701.csim"])
@pytest.mark.parametrize("fmt", ["text", "json", "sarif", "github", "gitlab"])
def test_family_diagnostics_use_the_project_renderers(name: str, fmt: str) -> None:
    path = CHECKS / name
    diagnostics = fatek.check_native([path]).diagnostics if path.suffix == ".fbs" \
        else csim.check_native([path]).diagnostics
    assert diagnostics
    expected = {"text": _text, "json": render_diagnostics_json, "sarif": render_sarif,
                "github": render_github, "gitlab": render_gitlab}[fmt](diagnostics)
    code, out, _ = run("lint", path, "--format", fmt)
    assert out == expected
    if fmt == "sarif":
        validated(out)
    assert code == (EXIT_SOURCE_ERRORS if name.startswith("E") else EXIT_OK)


def test_sarif_names_the_family_rules() -> None:
    code, out, _ = run("lint", CHECKS / "E604.fbs", "--format", "sarif")
    assert code == EXIT_SOURCE_ERRORS
    sarif = validated(out)
    results = sarif["runs"][0]["results"]
    assert {r["ruleId"] for r in results} == {"E604"}
    assert results[0]["locations"][0]["physicalLocation"]["region"]["startLine"] == 4
    assert "E604" in {rule["id"] for rule in sarif["runs"][0]["tool"]["driver"]["rules"]}


def test_text_lines_are_file_line_col() -> None:
    code, out, _ = run("lint", CHECKS / "E705.csim")
    assert code == EXIT_SOURCE_ERRORS
    first = out.splitlines()[0]
    assert first.startswith(f"{CHECKS / 'E705.csim'}:") and "error[E705]" in first


def test_werror_fails_on_family_warnings_and_ignore_comments_silence_them(
        tmp_path: Path) -> None:
    warned = tmp_path / "count.csim"
    warned.write_text("N1=0\nN1=N1+1\n")
    assert run("lint", warned)[0] == EXIT_OK
    code, out, _ = run("lint", warned, "--werror")
    assert code == EXIT_SOURCE_ERRORS and "warning[W701]" in out
    warned.write_text("N1=0\nN1=N1+1  # mpc: ignore[W701]\n")
    assert run("lint", warned, "--werror") == (EXIT_OK, "", "")
    fbs = tmp_path / "shape.fbs"
    fbs.write_text((CHECKS / "W601.fbs").read_text().replace(
        "    GOTO NEXT\n", "    GOTO NEXT  ; mpc: ignore[W601]\n", 1))
    code, out, _ = run("lint", fbs, "--werror", "--format", "json")
    assert code == EXIT_SOURCE_ERRORS
    assert [(d["code"], d["line"]) for d in json.loads(out)] == [("W601", 10)]


def test_lint_to_a_file(tmp_path: Path) -> None:
    report = tmp_path / "report.sarif"
    code, out, _ = run("lint", CHECKS / "E604.fbs", "--format", "sarif", "-o", report)
    assert (code, out) == (EXIT_SOURCE_ERRORS, "")
    assert validated(report.read_text())["version"] == "2.1.0"


def test_missing_input_and_mixed_families() -> None:
    assert run("lint", "missing.csim")[0] == EXIT_NO_INPUT
    code, _, err = run("lint", CHECKS / "E604.fbs", CHECKS / "E705.csim")
    assert code == EXIT_USAGE and "E604.fbs" in err and "E705.csim" in err


def test_the_compiled_build_and_the_lint_agree() -> None:
    source = SAMPLES / "fatek" / "gantry.mp"
    code, out, _ = run("lint", source, "--target", "fbs-fun140", "--format", "json")
    expected = fatek.compile_mp([source], Options(), "fbs-fun140").diagnostics
    assert code == EXIT_SOURCE_ERRORS
    assert out == render_diagnostics_json(expected)
