"""`.mp` to FBs-PLC tables: the sample programs end where their M8194H builds end, loops and
conditions are evaluated at compile time, and (hypothesis) any single-axis program of moves,
waits and constant loops ends at the same place on all three targets."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.fatek import FamilyBuild, check_native, compile_mp, run_build
from mplang.fatek.model import Condition, Drive, Line, ParamTable, PositioningTable, Register
from mplang.fatek.profile import load
from mplang.m8194h.compiler import Options, compile_paths, compile_source
from mplang.m8194h.run import run_build as run_m8194h

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "fatek"
TARGETS = ("fbs-fun140", "fbs-fun147")


def build_text(text: str, target: str, tmp_path: Path) -> FamilyBuild:
    path = tmp_path / "prog.mp"
    path.write_text(text, encoding="utf-8")
    return compile_mp([path], Options(), target)


def table_of(build: FamilyBuild, name: str | None = None) -> PositioningTable:
    tables = build.positioning_tables()
    return tables[0] if name is None else next(t for t in tables if t.name == name)


def m8194h_end(source: Path | str, call: str) -> dict[str, object]:
    result = compile_paths([source]) if isinstance(source, Path) else compile_source(source)
    assert result.ok, [d.render() for d in result.diagnostics]
    return run_m8194h(result, call).to_json()["axes"]  # type: ignore[return-value]


@pytest.mark.parametrize("target", TARGETS)
def test_the_feeder_ends_where_its_m8194h_build_ends(target: str) -> None:
    path = SAMPLES / "feeder.mp"
    build = compile_mp([path], Options(), target)
    assert build.ok and build.diagnostics == [], [d.render() for d in build.diagnostics]
    run = run_build(build, "feeder")
    assert run.finished
    assert run.to_json()["axes"] == m8194h_end(path, "feeder")
    assert run_build(build, "MP91").called == "feeder"  # the slot answers too
    table = table_of(build)
    assert len(table.steps) == 1 + 5 + 1 + 1  # start, five feeds, the slow one, home
    assert table.steps[-1].mend
    assert table.steps[4].speed == 5_000  # the inlined slow_feed


def test_the_feeder_on_fun140_writes_the_documented_forms() -> None:
    build = compile_mp([SAMPLES / "feeder.mp"], Options(), "fbs-fun140")
    table = table_of(build)
    assert table.steps[0].motion == Drive("DRV", "ABS", "", 1_000, "Ps")
    assert table.steps[1].condition == Condition("WAIT", time=25)  # TIMER 250 ms
    assert table.steps[-1].motion == Drive("DRV", "ABS", "", 0, "Ps")  # FB 66, 75
    (params,) = [t for t in build.programs if isinstance(t, ParamTable)]
    assert params.values == {5: 500, 8: 2_300}  # SET_SV; 460000 / SET_A 200000 = 2.3 s


def test_the_gantry_needs_fun147_and_then_ends_like_the_m8194h() -> None:
    path = SAMPLES / "gantry.mp"
    assert {d.code for d in compile_mp([path], Options(), "fbs-fun140").diagnostics} == \
        {"E643"}
    build = compile_mp([path], Options(), "fbs-fun147")
    assert build.ok and build.diagnostics == []
    run = run_build(build)
    assert run.finished and run.to_json()["axes"] == m8194h_end(path, "gantry")
    assert table_of(build).steps[0].motion == Line("LIN", "ADR", (8_000, 3_000, None, None),
                                                   "Ps")


@pytest.mark.parametrize("target", TARGETS)
def test_compiled_tables_write_out_and_check_back_clean(target: str, tmp_path: Path) -> None:
    build = compile_mp([SAMPLES / "feeder.mp"], Options(), target)
    path = tmp_path / "feeder.fbs"
    path.write_text(build.render("fbs"), encoding="utf-8")
    again = check_native([path])
    assert again.diagnostics == []
    assert again.programs == build.programs
    assert "????" in build.render("table")
    assert "feeder.mp:25" in build.render("listing")


def test_an_endless_label_loop_becomes_a_goto(tmp_path: Path) -> None:
    build = build_text("MP 1 cycle\n    SET_V X, 1000\nLABEL top\n    FIXED_MOVE X, 100\n"
                       "    STOP_WAIT X\n    TIMER 100\n    FIXED_MOVE X, -100\n"
                       "    STOP_WAIT X\n    GOTO top\nEND MP\n", "fbs-fun140", tmp_path)
    assert build.diagnostics == []
    first, second = table_of(build).steps
    assert first.condition == Condition("WAIT", time=10) and first.goto == "NEXT"
    assert second.condition == Condition("WAIT", time=0) and second.goto == 1
    run = run_build(build, max_time=3.0)
    assert not run.finished and "3 s" in (run.error or "")
    assert 0 <= run.positions[0] <= 100
    assert len(run.legs) > 4  # it went round the loop more than once


def test_a_loop_closes_when_its_state_repeats(tmp_path: Path) -> None:
    # VAR1 toggles 0, 1, 0, ...: two passes make the loop, then it repeats
    source = ("MP 1 toggle\n    SET_V X, 1000\n    VAR1 = 0\nLABEL top\n    VAR1 = 1 - VAR1\n"
              "    IF VAR1 == 1\n        FIXED_MOVE X, 300\n    ELSE\n        FIXED_MOVE X, -100\n"
              "    END IF\n    STOP_WAIT X\n    GOTO top\nEND MP\n")
    build = build_text(source, "fbs-fun140", tmp_path)
    assert build.diagnostics == []
    strokes = [s.motion.stroke for s in table_of(build).steps]  # type: ignore[union-attr]
    assert strokes == [300, 100]
    assert table_of(build).steps[-1].goto == 1


def test_known_values_fold_and_host_variables_become_registers(tmp_path: Path) -> None:
    source = ("MP 1 regs\n    VAR5 = 3\n    SET_V X, VAR4\n    FOR VAR5\n"
              "        FIXED_MOVE X, VAR3  # mpc: ignore[W103]\n        STOP_WAIT X\n    NEXT\n"
              "    VAR6 = VAR5 + 7\n    FIXED_MOVE X, VAR6\nEND MP\n")
    build = build_text(source, "fbs-fun140", tmp_path)
    assert [d.code for d in build.diagnostics] == ["W103"]  # VAR4 is the host's
    steps = table_of(build).steps
    assert len(steps) == 4
    assert steps[0].speed == Register("D", 8)
    assert steps[0].motion == Drive("DRV", "ADR", "", Register("D", 6), "Ps")
    assert steps[3].motion == Drive("DRV", "ADR", "+", 7, "Ps")  # VAR5 counted down to 0


def test_absolute_zero_is_written_as_drv_abs_0_as_fb_66_and_75_do(tmp_path: Path) -> None:
    """11.2 (FB 66, 75): `DRV ABS, ,0,Ut` goes to 0 mm, from a known position or not."""
    build = build_text("MP 1 a\n    SET_V X, 1000\n    ABS_FIXED_MOVE X, 700\n"
                       "    FIXED_MOVE X, 50\n    ABS_FIXED_MOVE X, 0\nEND MP\n",
                       "fbs-fun140", tmp_path)
    assert table_of(build).steps[-1].motion == Drive("DRV", "ABS", "", 0, "Ps")
    unknown = build_text("MP 1 a\n    SET_V X, 1000\n    FIXED_MOVE X, 50\n"
                         "    ABS_FIXED_MOVE X, 0\nEND MP\n", "fbs-fun140", tmp_path)
    assert unknown.ok and table_of(unknown).steps[-1].motion == Drive("DRV", "ABS", "", 0, "Ps")
    on_lines = build_text("MP 1 a\n    SET_V X, 1000\n    FIXED_MOVE X, 50\n"
                          "    ABS_FIXED_MOVE X, 0\nEND MP\n", "fbs-fun147", tmp_path)
    assert on_lines.ok  # LIN ABS,0 is a position (FB 2253-2259)


def test_the_literal_reading_of_fb_955_writes_absolute_zero_relatively(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """With semantics.abs_zero = 'continuous' (FB 955-957 read literally) a move to absolute
    0 becomes a relative move where the position is known, and E647 where it is not."""
    monkeypatch.setitem(load().raw["semantics"], "abs_zero", "continuous")
    build = build_text("MP 1 a\n    SET_V X, 1000\n    ABS_FIXED_MOVE X, 700\n"
                       "    FIXED_MOVE X, 50\n    ABS_FIXED_MOVE X, 0\nEND MP\n",
                       "fbs-fun140", tmp_path)
    assert table_of(build).steps[-1].motion == Drive("DRV", "ADR", "-", 750, "Ps")
    unknown = build_text("MP 1 a\n    SET_V X, 1000\n    FIXED_MOVE X, 50\n"
                         "    ABS_FIXED_MOVE X, 0\nEND MP\n", "fbs-fun140", tmp_path)
    assert [d.code for d in unknown.diagnostics] == ["E647"]


def test_called_programs_are_inlined_and_not_tables(tmp_path: Path) -> None:
    source = ("MP 1 main\n    SET_V X, 1000\n    CALL helper\n    FIXED_MOVE X, 5\nEND MP\n"
              "MP helper\n    FIXED_MOVE X, 10\n    EXIT\n    FIXED_MOVE X, 99\nEND MP\n"
              "MP 2 idle\n    VAR1 = 1\nEND MP\n")
    build = build_text(source, "fbs-fun140", tmp_path)
    assert [(d.code, d.span.line) for d in build.diagnostics] == [("W101", 9), ("E649", 11)]
    strokes = [s.motion.stroke for s in table_of(build, "main").steps]  # type: ignore[union-attr]
    assert strokes == [10, 5]
    assert [t.name for t in build.positioning_tables()] == ["main"]


def test_runtime_decisions_stop_the_evaluation_with_one_error(tmp_path: Path) -> None:
    source = ("MP 1 a\n    SET_V X, 1000\n    FOR VAR9\n        FIXED_MOVE X, 1\n    NEXT\n"
              "END MP\n")
    build = build_text(source, "fbs-fun140", tmp_path)
    assert [d.code for d in build.diagnostics if d.severity.value == "error"] == ["E641"]


def test_wait_rounding_and_trailing_waits_are_timing_warnings(tmp_path: Path) -> None:
    build = build_text("MP 1 a\n    SET_V X, 1000\n    FIXED_MOVE X, 5\n    STOP_WAIT X\n"
                       "    TIMER 25\n    FIXED_MOVE X, 5\n    STOP_WAIT X\n    TIMER 100\n"
                       "END MP\n", "fbs-fun140", tmp_path)
    assert [(d.code, d.span.line) for d in build.diagnostics] == [("W641", 5), ("W641", 8)]
    first = table_of(build).steps[0]
    assert first.condition == Condition("WAIT", time=3)


def test_each_compiled_table_json_names_its_source(tmp_path: Path) -> None:
    build = compile_mp([SAMPLES / "feeder.mp"], Options(), "fbs-fun147")
    data = build.to_json()
    assert data["format"] == "mplang-fatek/1"
    tables = data["tables"]
    assert isinstance(tables, list) and tables[0]["kind"] == "fun147"
    assert tables[0]["words"][:2] == [0xA55C, 8] and tables[0]["words"][2] is None
    assert tables[0]["steps"][0]["line"] == 25


# ------------------------------------------------------------------ the same end everywhere
actions = st.one_of(
    st.tuples(st.just("rel"), st.integers(-3_000, 3_000).filter(bool)),
    st.tuples(st.just("abs"), st.integers(-3_000, 3_000).filter(bool)),
    st.tuples(st.just("timer"), st.integers(0, 300)),
    st.tuples(st.just("speed"), st.integers(2_000, 60_000)),
)


@st.composite
def programs(draw: st.DrawFn) -> str:
    body = ["    SET_V X, 20000", "    FIXED_MOVE X, 2", "    STOP_WAIT X"]
    for _ in range(draw(st.integers(1, 4))):
        block = draw(st.lists(actions, min_size=1, max_size=4))
        lines = []
        for kind, value in block:
            if kind == "rel":
                lines += [f"FIXED_MOVE X, {value}", "STOP_WAIT X"]
            elif kind == "abs":
                lines += [f"ABS_FIXED_MOVE X, {value}", "STOP_WAIT X"]
            elif kind == "timer":
                lines.append(f"TIMER {value * 10}")
            else:
                lines.append(f"SET_V X, {value}")
        repeat = draw(st.integers(1, 3))
        if repeat > 1:
            body += [f"    FOR {repeat}", *(f"        {line}" for line in lines), "    NEXT"]
        else:
            body += [f"    {line}" for line in lines]
    body += ["    FIXED_MOVE X, 1", "    STOP_WAIT X"]
    return "MP 156 random\n" + "\n".join(body) + "\nEND MP\n"


@settings(max_examples=25, deadline=None)
@given(programs())
def test_any_single_axis_program_ends_alike_on_every_target(source: str) -> None:
    expected = m8194h_end(source, "random")
    for target in TARGETS:
        build = compile_source_fatek(source, target)
        assert build.ok, [d.render() for d in build.diagnostics]
        run = run_build(build, "random", max_time=1e5)
        assert run.finished, run.error
        assert run.to_json()["axes"] == expected


def compile_source_fatek(source: str, target: str) -> FamilyBuild:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "random.mp"
        path.write_text(source, encoding="utf-8")
        return compile_mp([path], Options(), target)
