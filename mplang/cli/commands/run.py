"""`mpc run`: build, load into a fresh virtual controller, call one program."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli.common import (
    EXIT_RUN_FAILED,
    build_options,
    expand_inputs,
    guarded,
    report,
    with_common,
)
from mplang.compiler import compile_paths


@click.command("run", short_help="Run one program on a fresh virtual controller.")
@click.argument("files", nargs=-1, required=True)
@click.option("--call", "call", default=None, metavar="MPn|NAME",
              help="Program to call [default: the first MP of the first file].")
@click.option("--json", "as_json", is_flag=True, help="Print variables, axes, time and error "
              "as JSON.")
@click.option("--max-time", type=click.FloatRange(min=0.001), default=3600.0, show_default=True,
              help="Give up after this much simulated time (seconds).")
@with_common
@guarded
def command(files: tuple[str, ...], call: str | None, as_json: bool, max_time: float, target: str,
        word_order: str | None, temp_vars: range, allow_outside_includes: bool,
        werror: bool) -> None:
    """Build FILE..., load every program into a fresh virtual controller and run one."""
    import json

    from mplang.run import NoSuchProgram, RunSetupError, run_build

    paths = expand_inputs(files)
    result = compile_paths(paths, build_options(target, word_order, temp_vars,
                                                allow_outside_includes))
    code = report(result, werror)
    if code:
        sys.exit(code)
    first = next((s for s in result.sources if Path(s).resolve() == paths[0].resolve()), None)
    try:
        outcome = run_build(result, call, first, max_time=max_time)
    except NoSuchProgram as exc:
        raise click.BadParameter(str(exc), param_hint="--call") from None
    except RunSetupError as exc:
        click.echo(f"mpc: {exc}", err=True)
        sys.exit(EXIT_RUN_FAILED)
    summary = outcome.to_json()
    if as_json:
        click.echo(json.dumps(summary, indent=1))
    else:
        click.echo(f"{outcome.called}: {'finished' if outcome.result.finished else 'FAILED'} "
                   f"after {summary['time_ms']} ms simulated, {outcome.result.steps} lines")
        for name, value in summary["vars"].items():  # type: ignore[attr-defined]
            click.echo(f"  {name} = {value}")
        for name, pos in summary["axes"].items():  # type: ignore[attr-defined]
            click.echo(f"  {name}: lp {pos['lp']}, ep {pos['ep']}")
        if outcome.result.error:
            click.echo(f"error: {outcome.result.error}", err=True)
    if not outcome.result.finished:
        sys.exit(EXIT_RUN_FAILED)
