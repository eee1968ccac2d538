"""`.mp` -> CSIM: the sample ends where its M8194H build ends; what cannot be expressed is
reported at the .mp line; conditions and loops behave as on the M8194H."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang import csim
from mplang.m8194h.compiler import Options, compile_paths
from mplang.m8194h.run import run_build as run_m8194h

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "samples" / "csim" / "cross_target.mp"


def compile_text(tmp_path: Path, text: str) -> csim.FamilyBuild:
    path = tmp_path / "t.mp"
    path.write_text(text)
    return csim.compile_mp([path], Options(), "csim")


def end_positions(report: dict[str, object]) -> dict[str, object]:
    axes = report["axes"]
    assert isinstance(axes, dict)
    return {name: value["lp"] for name, value in axes.items()}


def test_the_sample_ends_where_its_m8194h_build_ends() -> None:
    build = csim.compile_mp([SAMPLE], Options(), "csim")
    assert build.ok, [d.render() for d in build.diagnostics]
    assert {d.code for d in build.diagnostics} == {"W701", "W721"}
    outcome = csim.run_build(build, None, 1000.0)
    assert outcome.finished
    reference = run_m8194h(compile_paths([SAMPLE])).to_json()
    assert end_positions(outcome.to_json()) == end_positions(reference) == {
        "X": 6000, "Y": 0, "Z": 0, "U": 0}
    program = build.programs[0]
    assert program.variables["VAR1"] == "R0"
    # declared names since issue 14 item 2 (was {"R0": 2}): the name, and its CSIM variable
    assert outcome.to_json()["vars"] == {"laps": 2}
    assert outcome.to_json()["names"] == {"laps": "R0"}
    assert reference["vars"] == {"laps": 2} and reference["names"] == {"laps": "VAR1"}
    assert program.entries == {"cross_target": "$CROSS_TARGET", "MP131": "$CROSS_TARGET",
                               "park_y": "$PARK_Y"}


def test_the_compiled_program_checks_clean_as_a_native_script(tmp_path: Path) -> None:
    build = csim.compile_mp([SAMPLE], Options(), "csim")
    script = tmp_path / "cross_target.csim"
    script.write_text(build.render("csim"))
    native = csim.check_native([script])
    assert native.ok and {d.code for d in native.diagnostics} == {"W701"}
    assert native.programs[0].lines == build.programs[0].lines


def test_call_by_entry(tmp_path: Path) -> None:
    build = csim.compile_mp([SAMPLE], Options(), "csim")
    outcome = csim.run_build(build, "park_y", 100.0)
    assert outcome.called.endswith("$PARK_Y") and outcome.finished


def test_what_the_csim_cannot_express(tmp_path: Path) -> None:
    text = """
MP 1 a
    VAR1 = GET_LP(X)
    HOME_START Y
    VAR2 = VAR1 / 2
    TIMER VAR1
    SET_SV X, 100
    CALL MP9
END MP
ISR 1 b
    SET_V X, 1
END ISR
"""
    build = compile_text(tmp_path, text)
    got = {(d.code, d.span.line) for d in build.diagnostics}
    assert {("E721", 3), ("E722", 4), ("E722", 5), ("E722", 6), ("W721", 7),
            ("E724", 8), ("E724", 10)} <= got
    assert not build.ok


def test_arc_off_the_circle_and_assign_order(tmp_path: Path) -> None:
    text = """
MP 1 a
    ARC_CW 0, 100, 100, 50
    AXIS_ASSIGN Y, X, 0
    LINE_2D 10, 10
END MP
"""
    got = [(d.code, d.span.line) for d in compile_text(tmp_path, text).diagnostics]
    assert ("E722", 3) in got and ("E722", 4) in got and ("E722", 5) not in got


CMP = st.sampled_from(["<", ">", "<=", ">=", "==", "!="])
VALUE = st.integers(-5, 5)


@settings(max_examples=30, deadline=None)
@given(VALUE, CMP, VALUE, st.booleans(), st.integers(0, 3))
def test_if_and_for_behave_as_on_the_m8194h(tmp_path_factory: object, a: int, op: str, b: int,
                                            swap: bool, count: int) -> None:
    assert hasattr(tmp_path_factory, "mktemp")
    tmp_path = tmp_path_factory.mktemp("cmp")  # type: ignore[attr-defined]
    left, right = ("VAR1", str(b)) if not swap else (str(a), "VAR2")
    text = f"""
MP 91 t
    VAR1 = {a}
    VAR2 = {b}
    VAR3 = 0
    FOR {count}
        VAR3 = VAR3 + 1
    NEXT
    IF {left} {op} {right}
        VAR4 = 1
    ELSE
        VAR4 = 2
    END IF
    IF VAR1 {op} VAR2
        VAR5 = 3
    END IF
END MP
"""
    path = tmp_path / "t.mp"
    path.write_text(text)
    build = csim.compile_mp([path], Options(), "csim")
    assert build.ok, [d.render() for d in build.diagnostics]
    outcome = csim.run_build(build, None, 100.0, sample_period=None)
    mapping = build.programs[0].variables
    reference = run_m8194h(compile_paths([path])).to_json()["vars"]
    assert isinstance(reference, dict)
    got = outcome.to_json()["vars"]
    assert isinstance(got, dict)
    for var in ("VAR3", "VAR4", "VAR5"):
        assert got.get(mapping.get(var, "-"), 0) == reference.get(var, 0), (var, text)
