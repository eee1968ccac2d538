"""The family contract of issue 7, as the CLI will call it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mplang import csim
from mplang.m8194h.compiler import Options

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "samples" / "csim"


def test_names() -> None:
    assert csim.TARGETS == ("csim",)
    assert csim.SUFFIXES == (".csim",)


def test_check_native_never_raises_on_bad_input(tmp_path: Path) -> None:
    binary = tmp_path / "b.csim"
    binary.write_bytes(b"\xff\xfeMA 1\n")
    wrong = tmp_path / "w.txt"
    wrong.write_text("MA 1\n")
    build = csim.check_native([binary, wrong, tmp_path / "missing.csim"])
    assert not build.ok
    assert [(d.code, Path(d.span.file).name) for d in build.diagnostics] == [
        ("E701", "b.csim"), ("E701", "missing.csim"), ("E701", "w.txt")]
    with pytest.raises(ValueError, match="unknown CSIM target"):
        csim.check_native([], "fbs-fun140")


def test_renderings() -> None:
    build = csim.check_native([SAMPLES / "two_axis_2ma.csim"])
    assert build.render("csim") == "TX=0\nTY=1\n2MA 100,50\n"
    listing = build.render("listing")
    assert "0002  2MA 100,50  # " in listing and "two_axis_2ma.csim:6" in listing
    data = json.loads(build.render("json"))
    assert data == build.to_json()
    assert data["format"] == "mplang-csim/1" and data["ok"] is True
    assert data["programs"][0]["lines"][2] == {
        "address": 2, "text": "2MA 100,50", "origin": f"{SAMPLES / 'two_axis_2ma.csim'}:6:1"}
    with pytest.raises(ValueError):
        build.render("hex")


def test_warnings_can_be_silenced_like_in_mp(tmp_path: Path) -> None:
    path = tmp_path / "s.csim"
    path.write_text("N1=N1+1  # mpc: ignore[W701]\nN2=N2+1\n")
    assert [(d.code, d.span.line) for d in csim.check_native([path]).diagnostics] == [
        ("W701", 2)]


def test_run_json_has_the_keys_of_mpc_run() -> None:
    build = csim.compile_mp([SAMPLES / "cross_target.mp"], Options(), "csim")
    outcome = csim.run_build(build, None, 1000.0)
    report = outcome.to_json()
    assert set(report) == {"called", "vars", "names", "axes", "time_ms", "error"}
    assert set(report["axes"]) == {"X", "Y", "Z", "U"}  # type: ignore[arg-type]
    assert outcome.finished and outcome.error is None
    assert outcome.samples[0][0] == 0.0
    assert outcome.samples[-1][1]["X"] == 6000
    json.dumps(report)


def test_a_failed_build_does_not_run(tmp_path: Path) -> None:
    path = tmp_path / "bad.csim"
    path.write_text("FOO\n")
    with pytest.raises(csim.RunSetupError):
        csim.run_build(csim.check_native([path]), None, 1.0)


def test_unused_modules_appear_once_used(tmp_path: Path) -> None:
    path = tmp_path / "t.csim"
    path.write_text("PN50=255\n")  # immediate only: refused in a program
    assert not csim.check_native([path]).ok


def test_an_unknown_call_lists_the_callable_programs_entries_and_labels() -> None:
    from mplang.csim import check_native
    from mplang.csim.run import NoSuchProgram, run_build

    build = check_native([ROOT / "samples" / "csim" / "program_flow.csim"])
    with pytest.raises(NoSuchProgram) as caught:
        run_build(build, "nosuch", 1.0)
    assert "; callable: program_flow, " in str(caught.value)
    assert "program_flow:$ROUND" in str(caught.value)
