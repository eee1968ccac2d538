"""Which build a document is checked in: its project's sources with the project's options, or
the document alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.m8194h.compiler import DEFAULT_TEMPS, compile_paths
from mplang.tools.lsp import features
from mplang.tools.lsp.analysis import analyse
from mplang.tools.lsp.positions import Pos
from mplang.tools.lsp.workspace import Overrides, context_for

JOB = "MP 96 job\n    CALL homing\n    VAR_USE = 1\nEND MP\n"
HOMING = "VAR VAR_USE\nMP homing\n    HOME_START X\nEND MP\n"


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "job.mp").write_text(JOB)
    (tmp_path / "src" / "homing.mp").write_text(HOMING)
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["src"]\ntarget = "rs"\n'
                                       'temp-vars = "480-491"\nvar-pool = "300-309"\n\n'
                                       '[slots]\nhoming = "MP41"\n')
    return tmp_path


def test_a_file_outside_any_project_is_checked_alone(tmp_path: Path) -> None:
    context = context_for(tmp_path / "a.mp")
    assert context.sources == (tmp_path / "a.mp",) and context.project_file is None
    assert context.options.target == "et" and context.options.temps == DEFAULT_TEMPS


def test_a_project_source_is_checked_with_all_sources_and_the_projects_options(
        project: Path) -> None:
    context = context_for(project / "src" / "job.mp")
    assert context.project_file == project / "mpc.toml"
    assert context.sources == ((project / "src" / "homing.mp").resolve(),
                               (project / "src" / "job.mp").resolve())
    options = context.options
    assert (options.target, options.temps, options.var_pool) == ("rs", range(480, 492),
                                                                  range(300, 310))
    assert [pin.name for pin in options.pins] == ["homing"]


def test_command_line_options_win_over_the_project_file(project: Path) -> None:
    context = context_for(project / "src" / "job.mp", Overrides("et", range(490, 500), True))
    assert context.options.target == "et" and context.options.temps == range(490, 500)
    assert context.options.allow_outside_includes


def test_a_file_that_is_no_project_source_is_checked_alone_without_pins(project: Path
                                                                        ) -> None:
    context = context_for(project / "scratch.mp")
    assert context.sources == (project / "scratch.mp",)
    assert context.options.pins == () and context.options.target == "rs"


def test_a_broken_project_file_is_reported_and_left_out(project: Path) -> None:
    (project / "mpc.toml").write_text('[project]\ntarget = "xx"\n')
    context = context_for(project / "src" / "job.mp")
    assert context.problem.startswith(f"{project / 'mpc.toml'}:2: [project] target")
    assert context.problem.endswith("(checked without the project file)")
    analysis = analyse(project / "src" / "job.mp", JOB, context)
    first = analysis.diagnostics[0]
    assert first.message == context.problem and first.range.start.line == 0


def test_the_project_build_agrees_with_mpc_build(project: Path) -> None:
    job = project / "src" / "job.mp"
    analysis = analyse(job, JOB, context_for(job))
    # CALL homing finds the program of the other source file, without an INCLUDE.
    assert analysis.diagnostics == []
    main = analysis.program_named("job")
    homing = analysis.program_named("homing")
    assert main is not None and homing is not None and homing.path.name == "homing.mp"
    use = analysis.slot_use(homing)
    assert use is not None and use.summary == "MP41: 2/16 lines"  # the pin, not auto-placed
    built = compile_paths([project / "src" / "homing.mp", job], context_for(job).options)
    assert built.ok and [(v.name, v.index) for v in built.variables] == [("VAR_USE", 300)]
    assert analysis.alias_targets["VAR_USE"] == 300
    hover = features.hover(analysis, Pos(2, 5))
    assert hover is not None and hover.markdown.startswith(
        "**VAR VAR_USE** = VAR300 (the first free of the pool VAR300..VAR309)")
    (where,) = features.definition(analysis, Pos(2, 5))
    assert where.path.name == "homing.mp" and where.range.start.line == 0
    starts = {e.label: e for e in features.completion(analysis, Pos(2, 0))}
    assert starts["VAR_USE"].detail == "VAR300"


def test_problems_of_other_sources_stay_with_their_own_document(project: Path) -> None:
    job = project / "src" / "job.mp"
    (project / "src" / "homing.mp").write_text(HOMING.replace("HOME_START X", "HOME_STRT X"))
    analysis = analyse(job, JOB, context_for(job))
    assert analysis.diagnostics == []
    other = analyse(project / "src" / "homing.mp",
                    (project / "src" / "homing.mp").read_text(),
                    context_for(project / "src" / "homing.mp"))
    assert [d.code for d in other.diagnostics] == ["E201"]


def test_slot_pin_problems_show_on_the_first_line(project: Path) -> None:
    (project / "mpc.toml").write_text('[project]\nsources = ["src"]\n\n[slots]\n'
                                      'nothing = "MP3"\n')
    job = project / "src" / "job.mp"
    analysis = analyse(job, JOB, context_for(job))
    (pin,) = analysis.diagnostics
    assert pin.code == "W109" and pin.range.start.line == 0
    assert "mpc.toml:5" in pin.message
