"""Names in traces and plots (issue 14 item 2): `mpc run --trace` heads a column per
declared variable (VAR name, ALIAS) with its name and device number, and `mpc plot` draws
the ones that change under the same labels (the matplotlib figure read back, Agg canvas)."""

from __future__ import annotations

import csv
from pathlib import Path

from click.testing import CliRunner

from mplang.cli import main
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import run_build
from mplang.tools.plot import PlotRequest, build_figure

NAMED = """ALIAS parts = VAR10
VAR rows_done @ VAR400
VAR spare

MP 100 job
    SET_V X, 20000
    parts = 0
    rows_done = 0
    FOR 3
        FIXED_MOVE X, 1000
        STOP_WAIT X
        parts = parts + 1
        rows_done = rows_done + 2
    NEXT
END MP
"""


def test_trace_csv_heads_declared_variables_by_name(tmp_path: Path) -> None:
    source = tmp_path / "job.mp"
    source.write_text(NAMED)
    trace_file = tmp_path / "job.csv"
    result = CliRunner().invoke(main, ["run", str(source), "--trace", str(trace_file)])
    assert result.exit_code == 0, result.output
    rows = list(csv.reader(trace_file.open()))
    header = rows[0]
    assert header[:4] == ["time_s", "X_lp", "X_ep", "X_velocity"]
    assert header[13:] == ["parts (VAR10)", "rows_done (VAR400)", "spare (VAR401)", "source"]
    first, last = dict(zip(header, rows[1], strict=True)), dict(zip(header, rows[-1],
                                                                     strict=True))
    assert (first["parts (VAR10)"], first["rows_done (VAR400)"]) == ("0", "0")
    assert (last["parts (VAR10)"], last["rows_done (VAR400)"], last["spare (VAR401)"]) == \
        ("3", "6", "0")
    assert "  parts (VAR10) = 3" in result.stdout


def test_a_trace_of_a_program_without_declarations_has_the_axis_columns_only() -> None:
    build = compile_source("MP 1\n    VAR1 = 5\nEND MP\n")
    trace = run_build(build, trace_period=0.001).trace
    assert trace is not None and trace.variables == ()
    assert trace.header()[-2:] == ["U_velocity", "source"]


def test_plot_legend_names_the_variables_that_change() -> None:
    build = compile_source(NAMED, "job.mp")
    report = run_build(build, trace_period=0.001)
    assert report.trace is not None
    figure = build_figure(report.trace, PlotRequest("MP100 job (job.mp)"))
    panels = [axes for sub in figure.subfigs for axes in sub.axes]
    variables = [axes for axes in panels if axes.get_title() == "variables"]
    assert len(variables) == 1
    legend = variables[0].get_legend()
    assert legend is not None
    assert [text.get_text() for text in legend.get_texts()] == \
        ["parts (VAR10)", "rows_done (VAR400)"]  # spare never changes: no line
    assert figure.get_suptitle() == "MP100 job (job.mp)"


def test_plot_title_names_the_program_by_its_declared_name(tmp_path: Path) -> None:
    from mplang import m8194h

    source = tmp_path / "job.mp"
    source.write_text(NAMED)
    build = m8194h.compile_mp([source], m8194h.Options(), "et")
    run = m8194h.run_build(build, None, 60.0, sample_period=0.001)
    assert run.plot_title("M8194H", str(source)) == f"MP100 job ({source})"
    image = tmp_path / "job.png"
    result = CliRunner().invoke(main, ["plot", str(source), "-o", str(image)])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("MP100: finished after ")
