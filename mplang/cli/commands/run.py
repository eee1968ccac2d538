"""`mpc run`: build, load into a fresh virtual controller, call one program; `--trace` also
writes every axis's position and velocity over the run as CSV. FATEK and CSIM builds run on
their family's virtual controller, with the same summary and trace columns."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mplang.cli.common import (
    OutputError,
    build_setup,
    guarded,
    machine_option,
    project_option,
    with_common,
)
from mplang.cli.families import choose, watched_run
from mplang.cli.runwatch import (
    exit_code,
    given,
    max_time_option,
    out_of_time_hint,
)
from mplang.cli.shell import complete_paths, complete_programs
from mplang.cli.style import quiet_option

if TYPE_CHECKING:
    from mplang.family.trace import Trace


def check_trace_place(trace_file: str) -> None:
    """Refuse, before the run, a trace file that cannot be a file: '-', a directory, or a
    place in a directory that does not exist."""
    path = Path(trace_file)
    if trace_file == "-":
        raise click.BadParameter("the trace goes to a file, not standard output",
                                 param_hint="--trace")
    if path.is_dir():
        raise OutputError(f"cannot write {trace_file}: it is a directory")
    if not path.parent.is_dir():
        raise OutputError(f"cannot write {trace_file}: no directory {path.parent}")


@click.command("run", short_help="Run one program on a fresh virtual controller.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--call", "call", default=None, metavar="MPn|NAME",
              shell_complete=complete_programs,
              help="Program to call [default: the first MP of the first file]; FATEK: a "
              "table NAME[:STEP]; CSIM: a program, an MP's name or a $LABEL.")
@click.option("--json", "as_json", is_flag=True, help="Print variables, axes, time and error "
              "as JSON.")
@max_time_option
@click.option("--trace", "trace_file", default=None, metavar="FILE.csv",
              shell_complete=complete_paths,
              help="Also write time, and LP, EP and velocity of every axis, as CSV.")
@click.option("--trace-period", type=click.FloatRange(min=0.00001), default=None,
              metavar="SECONDS", help="Sampling period of --trace in simulated time "
              "[default: 0.001; motion ends are sampled too].")
@machine_option
@project_option
@quiet_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], call: str | None, as_json: bool,
            max_time: float, trace_file: str | None, trace_period: float | None,
            machine_file: Path | None, project_file: Path | None, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Build FILE..., load every program into a fresh virtual controller and run one."""

    from mplang.family.trace import DEFAULT_PERIOD

    if trace_period is not None and trace_file is None:
        raise click.UsageError("--trace-period needs --trace FILE.csv")
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    selection = choose(setup)
    if trace_file is not None:
        check_trace_place(trace_file)
    period = None if trace_file is None \
        else DEFAULT_PERIOD if trace_period is None else trace_period
    run, watch = watched_run("mpc run", selection, setup, call, max_time, period,
                             machine_file)
    interrupted = watch.interrupted and not run.finished
    trace = run.trace
    if trace_file is not None and trace is not None:
        _write_trace(trace, trace_file)
    summary = dict(run.to_json())
    if interrupted:  # only then: the summary of a run that ended by itself is unchanged
        summary["interrupted"] = watch.interrupted_json()
    state = "finished" if run.finished else "INTERRUPTED" if interrupted else "FAILED"
    headline = (f"{run.called}: {state} after "
                f"{summary['time_ms']} ms simulated{run.headline_detail(selection.describe)}")
    failure = run.failure
    error = failure.render() if failure is not None else run.error
    if failure is not None and failure.code == "R202":
        error = f"{error}\n{out_of_time_hint(max_time, given(ctx, 'max_time'))}"
    _summarise(summary, as_json, headline, trace, trace_file,
               watch.interrupted_note() if interrupted else error)
    for warning in run.warnings:  # commands the virtual controller does not simulate
        click.echo(warning, err=True)
    if not run.finished:
        sys.exit(exit_code(interrupted, failure.code if failure is not None else None))


def _write_trace(trace: Trace, trace_file: str) -> None:
    try:
        with open(trace_file, "w", encoding="utf-8", newline="") as stream:
            trace.write_csv(stream)
    except OSError as exc:
        raise OutputError(f"cannot write {trace_file}: {exc.strerror or exc}") from None


def _summarise(summary: Mapping[str, Any], as_json: bool, headline: str, trace: Trace | None,
               trace_file: str | None, error: str | None) -> None:
    """`mpc run`'s output for every family: the JSON summary, or the headline, variables,
    axes and trace file in words (the run-time finding on standard error)."""
    import json

    if as_json:
        click.echo(json.dumps(summary, indent=1))
        return
    click.echo(headline)
    numbers = summary.get("names") or {}
    for name, value in summary["vars"].items():
        number = f" ({numbers[name]})" if name in numbers else ""
        click.echo(f"  {name}{number} = {value}")
    for name, pos in summary["axes"].items():
        click.echo(f"  {name}: lp {pos['lp']}, ep {pos['ep']}")
    if trace is not None:
        click.echo(f"  trace: {len(trace)} samples written to {trace_file}")
    if error:  # `file:line:col: error[Rnnn]: ...` (docs/runtime/), or where Ctrl-C stopped
        click.echo(error, err=True)
