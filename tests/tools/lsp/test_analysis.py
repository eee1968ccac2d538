"""The analysis layer: the compiler's diagnostics placed in the open document, definitions,
program blocks and slot budgets, including while the document has errors."""

from __future__ import annotations

from pathlib import Path

import pytest
from parsecount import CountedParse

from mplang.lang.linecache import StatementCache
from mplang.m8194h.compiler import compile_paths
from mplang.tools.lsp.analysis import analyse
from mplang.tools.lsp.positions import Pos, line_range
from mplang.tools.report import check_page

DATA = Path(__file__).resolve().parents[2] / "data" / "checks"
MAIN = """INCLUDE "common.mp"
ALIAS count = VAR1

MP 21 main
    SET_V X, SPEED
    FIXD_MOVE X, 1000
    LABEL top
    count = count + 1
    GOTO top
END MP

MP helper
    ABS_FIXED_MOVE X, 0
END MP
"""
COMMON = "CONST SPEED = 2000 * 2\nMP shared\n    BAD_COMMAND 3\nEND MP\n"


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / ".git").mkdir()
    (tmp_path / "common.mp").write_text(COMMON)
    return tmp_path


def test_diagnostics_keep_code_severity_hint_and_0_based_range(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN)
    unknown = next(d for d in analysis.diagnostics if d.code == "E201" and "FIXD" in d.message)
    # The compiler reports main.mp:6:5 (1-based); the editor counts from 0.
    assert unknown.range == line_range(5, 4, 13)
    assert unknown.severity == "error"
    assert unknown.hint == "did you mean FIXED_MOVE?"
    assert unknown.docs == check_page("E201") and unknown.docs is not None
    assert unknown.docs.name == "E201.md" and unknown.docs.is_file()
    warning = next(d for d in analysis.diagnostics if d.code == "W103")
    assert warning.severity == "warning"


def test_a_problem_in_an_included_file_is_shown_on_its_include_line(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN)
    inside = next(d for d in analysis.diagnostics if "BAD_COMMAND" in d.message)
    assert inside.range == line_range(0, 8, 19)  # the quoted "common.mp"
    assert "common.mp:3:5" in inside.message
    (where, _note), *_ = inside.related
    assert where.path == project / "common.mp" and where.range == line_range(2, 4, 15)


@pytest.mark.parametrize("source", sorted(DATA.glob("*.mp")), ids=lambda p: p.name)
def test_every_check_example_is_placed_at_the_compilers_line_and_column(source: Path) -> None:
    analysis = analyse(source, source.read_text(encoding="utf-8"))
    own = [d for d in compile_paths([source]).diagnostics
           if Path(d.span.file).resolve() == source.resolve()]
    placed = {(d.code, d.range.start.line) for d in analysis.diagnostics}
    for diagnostic in own:
        assert (diagnostic.code, diagnostic.span.line - 1) in placed
        line = analysis.lines[diagnostic.span.line - 1]
        if diagnostic.span.col <= len(line):
            starts = {d.range.start.character for d in analysis.diagnostics
                      if d.code == diagnostic.code}
            assert diagnostic.span.col - 1 in starts


def test_definitions_come_from_every_file_of_the_build(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN)
    speed = analysis.consts["SPEED"]
    assert speed.location.path == project / "common.mp"
    assert speed.location.range == line_range(0, 6, 11)
    assert speed.text == "CONST SPEED = 2000 * 2"
    assert analysis.const_values["SPEED"] == 4000
    assert analysis.aliases["COUNT"].location.range == line_range(1, 6, 11)
    assert analysis.alias_targets == {"COUNT": 1}
    assert [p.title for p in analysis.programs] == ["MP 21 main", "MP helper", "MP shared"]


def test_program_blocks_and_labels(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN)
    main = analysis.program_named("MAIN")
    assert main is not None and (main.first_line, main.last_line) == (3, 9)
    assert main.name_range == line_range(3, 6, 10)
    assert main.labels["TOP"].location.range == line_range(6, 10, 13)
    assert analysis.program_at(7) is main
    assert analysis.program_at(10) is None


def test_slot_budgets_show_while_the_build_has_errors(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN)
    main, helper = analysis.program_named("main"), analysis.program_named("helper")
    assert main is not None and helper is not None
    # SET_V, LABEL, the assignment, GOTO and END MP compile; the misspelt line does not.
    use = analysis.slot_use(main)
    assert use is not None and use.summary == "MP21: 5/8 lines"
    helper_use = analysis.slot_use(helper)
    assert helper_use is not None and helper_use.summary == "MP1: 2/8 lines (auto-placed)"
    assert analysis.program_in_slot("mp", 1) is helper


def test_over_budget_and_unplaced_programs() -> None:
    body = "    SET_V X, 1\n" * 9
    text = f"MP 1 small\n{body}END MP\nMP 157\n{body * 60}END MP\nMP big\n{body * 60}END MP\n"
    analysis = analyse(Path("budget.mp"), text)
    summaries = [analysis.slot_use(p).summary for p in analysis.programs]  # type: ignore[union-attr]
    assert summaries == ["MP1: 10/8 lines, over budget", "MP157: 541/512 lines, over budget",
                         "MP: 541 lines, no slot"]


def test_an_open_buffer_is_read_instead_of_the_disk(project: Path) -> None:
    edited = {project / "common.mp": "CONST SPEED = 7\n"}
    analysis = analyse(project / "main.mp", MAIN, open_texts=edited)
    assert analysis.const_values["SPEED"] == 7
    assert not any("BAD_COMMAND" in d.message for d in analysis.diagnostics)


def test_an_include_through_a_parent_directory_finds_the_open_buffer(project: Path) -> None:
    (project / "sub").mkdir()
    text = 'INCLUDE "../common.mp"\nMP 1\n    SET_V X, SPEED\nEND MP\n'
    analysis = analyse(project / "sub" / "m.mp", text,
                       open_texts={project / "common.mp": "CONST SPEED = 9\n"})
    assert analysis.const_values["SPEED"] == 9
    assert analysis.includes[0].target == project / "common.mp"


def test_syntax_errors_leave_the_rest_indexed(project: Path) -> None:
    text = MAIN.replace("    LABEL top\n", "    LABEL top\n    FOR 3 (\n    NEXT\n")
    analysis = analyse(project / "main.mp", text)
    assert any(d.code == "E101" for d in analysis.diagnostics)
    main = analysis.program_named("main")
    assert main is not None and "TOP" in main.labels
    assert analysis.program_at(Pos(9, 0).line) is main


def test_unclosed_program_runs_to_the_end_of_the_file() -> None:
    analysis = analyse(Path("open.mp"), "MP 3 typing\n    SET_V X, 1\n\n")
    (program,) = analysis.programs
    assert (program.first_line, program.last_line) == (0, 3)
    assert any(d.code == "E302" for d in analysis.diagnostics)


def test_variables_used_anywhere_in_the_build(project: Path) -> None:
    analysis = analyse(project / "main.mp", MAIN + "MP 2\n    VAR7 = var9\nEND MP\n")
    assert analysis.variables_used == {1, 7, 9}
    assert analysis.alias_names_of(1) == ["count"]


def test_a_compiler_failure_becomes_one_diagnostic_and_commands_still_hover(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from mplang.tools.lsp import analysis as module
    from mplang.tools.lsp import features

    def broken(*_args: object, **_kwargs: object) -> None:
        raise RecursionError("maximum recursion depth exceeded")

    monkeypatch.setattr(module, "compile_sources", broken)
    analysis = analyse(Path("crash.mp"), "MP 1\n    SET_V X, 1\nEND MP\n")
    (only,) = analysis.diagnostics
    assert only.message == ("mpc could not check this text: RecursionError: maximum "
                            "recursion depth exceeded")
    assert only.range == line_range(0, 0, 0) and only.severity == "error"
    found = features.hover(analysis, Pos(1, 6))
    assert found is not None and found.markdown.startswith("**SET_V**")


def test_interrupt_wiring_counts_in_the_setup_programs_budget() -> None:
    text = ("INTERRUPTS go\n    ON XY D-END CALL ISR 1\nEND INTERRUPTS\n"
            "MP 1 go\n    SET_V X, 1\nEND MP\nISR 1\n    VAR1 = 1\nEND ISR\n")
    analysis = analyse(Path("wired.mp"), text)
    go = analysis.program_named("go")
    assert go is not None
    use = analysis.slot_use(go)
    # INTFACTOR_ENABLE for X and for Y, ENABLE_INT, SET_V and END MP
    assert use is not None and use.summary == "MP1: 5/8 lines"


@pytest.mark.parametrize(("target", "code"), [("csim", "E721"), ("fbs-fun140", "E640")])
def test_a_family_project_is_checked_by_its_family(tmp_path: Path, target: str,
                                                   code: str) -> None:
    from mplang.tools.lsp.workspace import context_for

    (tmp_path / "mpc.toml").write_text(f'[project]\nsources = ["job.mp"]\ntarget = "{target}"\n')
    job = tmp_path / "job.mp"
    text = "INIT\n    SERVO_ON X\nEND INIT\nMP 1 go\n    SET_V X, 1000\n" \
        "    FIXED_MOVE X, 100\nEND MP\n"
    job.write_text(text)
    analysis = analyse(job, text, context_for(job))
    found = [(d.code, d.range.start.line) for d in analysis.diagnostics]
    assert (code, 0) in found, found
    assert not any("could not check" in d.message for d in analysis.diagnostics)
    go = analysis.program_named("go")
    assert go is not None and analysis.slot_use(go) is not None


def test_one_change_is_one_analysis(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """didChange: the document is parsed once and lowered once (the compiler's pass also
    gives the definitions and the slot budgets), and an included file that did not change
    comes from the front-end cache. Counted through the parser's hook and the lowering."""
    from mplang.ir import unit as unit_module
    from mplang.lang import parser
    from mplang.m8194h import compiler
    from mplang.tools.lsp import analysis as module

    monkeypatch.setenv("MPLANG_CACHE", str(tmp_path / "cache"))
    (tmp_path / ".git").mkdir()
    (tmp_path / "common.mp").write_text(COMMON)
    parsed: list[str] = []
    lowered: list[int] = []
    original = unit_module.lower_unit

    def counted(*args: object, **kwargs: object) -> object:
        lowered.append(1)
        return original(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(compiler, "lower_unit", counted)
    monkeypatch.setattr(module, "lower_unit", counted)
    monkeypatch.setattr(parser, "PARSE_HOOKS", [parsed.append])
    path = tmp_path / "main.mp"
    first = analyse(path, MAIN)
    assert sorted(Path(p).name for p in parsed) == ["common.mp", "main.mp"]
    assert len(lowered) == 1
    parsed.clear()
    lowered.clear()
    changed = analyse(path, MAIN.replace("FIXD_MOVE", "FIXED_MOVE"))
    assert [Path(p).name for p in parsed] == ["main.mp"] and len(lowered) == 1
    assert [d.code for d in first.diagnostics if "FIXD_MOVE" in d.message] == ["E201"]
    assert not [d for d in changed.diagnostics if "FIXD_MOVE" in d.message]
    assert changed.slot_use(changed.programs[0]) is not None
    assert set(changed.consts) == {"SPEED"} and changed.const_values["SPEED"] == 4000
    # the include read from disk is kept for the next change, the editor's buffer is not
    assert len(list((tmp_path / "cache" / "front").iterdir())) == 1


def test_an_edit_is_analysed_parsing_the_edited_line_only(project: Path) -> None:
    """The server keeps one statement cache: an edit then parses its own line, and the
    analysis equals that of the same text checked afresh (diagnostics and their places)."""
    path = project / "main.mp"
    path.write_text(MAIN)
    counted = CountedParse()
    cache = StatementCache(counted)  # type: ignore[arg-type]
    analyse(path, MAIN, lines=cache)
    assert "".join(counted.texts).count("FIXD_MOVE X, 1000") == 1
    counted.texts.clear()
    edited = MAIN.replace("FIXD_MOVE X, 1000", "FIXD_MOVE X, 1700").replace(
        "GOTO top", "GOTO nowhere")
    incremental = analyse(path, edited, lines=cache)
    assert counted.texts == ["    FIXD_MOVE X, 1700\n    GOTO nowhere"]
    fresh = analyse(path, edited)
    assert incremental.diagnostics == fresh.diagnostics
    assert any("nowhere" in d.message for d in incremental.diagnostics)
