"""`mpc plot`: run one program on a fresh virtual controller of its family and draw its tool
path and the position and velocity of every moving axis against time (PNG or SVG)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from mplang.cli import style
from mplang.cli.common import (
    OutputError,
    build_setup,
    guarded,
    machine_option,
    project_option,
    require_extra,
    with_common,
)
from mplang.cli.families import choose, watched_run
from mplang.cli.runwatch import exit_code, given, max_time_option, out_of_time_hint
from mplang.cli.shell import complete_paths, complete_programs
from mplang.cli.style import quiet_option

if TYPE_CHECKING:
    from mplang.family.trace import Trace

IMAGE_SUFFIXES = {".png": "png", ".svg": "svg"}


def image_format(output: str) -> str:
    """png or svg, from the output file's suffix; anything else is a usage error."""
    fmt = IMAGE_SUFFIXES.get(Path(output).suffix.lower())
    if fmt is None:
        raise click.BadParameter(f"{output!r}: name a file ending in .png or .svg",
                                 param_hint="'-o' / '--output'")
    return fmt


def require_matplotlib() -> None:
    """matplotlib is the optional `plot` extra: say how to get it before a possibly long
    simulation, instead of failing on the import after it."""
    require_extra("mpc plot", "plot", "matplotlib")


def check_output_place(output: Path) -> None:
    """Refuse, before a possibly long simulation, an output whose directory is missing or
    that names a directory."""
    if output.is_dir():
        raise OutputError(f"cannot write {output}: it is a directory")
    if not output.parent.is_dir():
        raise OutputError(f"cannot write {output}: no directory {output.parent}")


@click.command("plot", short_help="Plot the simulated tool path and axis motion (PNG/SVG).")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--call", "call", default=None, metavar="MPn|NAME",
              shell_complete=complete_programs,
              help="Program to call [default: the first MP of the first file]; FATEK: a "
              "table NAME[:STEP]; CSIM: a program, an MP's name or a $LABEL.")
@click.option("-o", "--output", required=True, metavar="OUT.png|OUT.svg",
              shell_complete=complete_paths,
              help="Image to write; the format follows the suffix.")
@click.option("--width", type=click.IntRange(300, 8000), default=1200, show_default=True,
              help="Image width in pixels.")
@click.option("--height", type=click.IntRange(300, 8000), default=900, show_default=True,
              help="Image height in pixels.")
@click.option("--trace-period", type=click.FloatRange(min=0.00001), default=0.001,
              show_default=True, metavar="SECONDS",
              help="Sample the axes this often (simulated time; motion ends are sampled too).")
@max_time_option
@machine_option
@project_option
@quiet_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], call: str | None, output: str,
            width: int, height: int, trace_period: float, max_time: float,
            machine_file: Path | None, project_file: Path | None, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Build FILE..., run one program on a fresh virtual controller and plot what the axes
    did: the XY path (XZ and YZ too when Z moves) and position and velocity against time.
    A program that fails or does not finish is plotted up to that point, and exits 5."""
    fmt = image_format(output)
    require_matplotlib()
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    selection = choose(setup)
    check_output_place(Path(output))
    run, watch = watched_run("mpc plot", selection, setup, call, max_time, trace_period,
                             machine_file)
    interrupted = watch.interrupted and not run.finished
    trace = run.trace
    assert trace is not None  # asked for with trace_period
    sources = ", ".join(str(p) for p in setup.paths)
    for warning in run.warnings:  # unmodelled commands, axes stopped (R301-R315)
        click.echo(warning, err=True)
    failure = run.failure
    error = failure.render() if failure is not None else run.error
    if interrupted:
        error = watch.interrupted_note()
    code = exit_code(interrupted, failure.code if failure is not None else None)
    hint = out_of_time_hint(max_time, given(ctx, "max_time")) \
        if failure is not None and failure.code == "R202" else None
    _draw(trace, run.plot_title(selection.describe, sources), run.called,
          "finished" if run.finished else "INTERRUPTED" if interrupted else "FAILED",
          run.time_s, error, (fmt, width, height), trace_period, output)
    if not run.finished:
        if error:  # `file:line:col: error[Rnnn]: ...` (docs/runtime/), or where Ctrl-C stopped
            click.echo(error, err=True)
            if hint:
                click.echo(hint, err=True)
        else:
            style.error("the program did not finish")
        sys.exit(code)


def _draw(trace: Trace, heading: str, called: str, state: str, time_s: float,
          error: str | None, image_shape: tuple[str, int, int], trace_period: float,
          output: str) -> None:
    """Render the run's trace under `heading` into `output` (format, width, height from
    `image_shape`) and say so (every family plots here)."""
    from mplang.tools.plot import PlotRequest, render

    title = (f"{heading}\n{state} after {time_s:.3f} s simulated, sampled every "
             f"{trace_period * 1000:g} ms")
    if error:
        title += f"\n{error}"
    image = render(trace, PlotRequest(title, *image_shape))
    try:
        Path(output).write_bytes(image)
    except OSError as exc:
        raise OutputError(f"cannot write {output}: {exc.strerror or exc}") from None
    click.echo(f"{called}: {state} after {round(time_s * 1000, 3)} ms simulated; "
               f"{len(trace)} samples plotted to {output}")
