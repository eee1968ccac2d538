"""`mpc call`: start a program on a device by its declared name, after checking that the
device holds the build of FILE... (`mplang.host`); with --wait, until it ends, reporting the
declared variables it writes and any execution error at its source line."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

import click

from mplang.cli.common import EXIT_OK, EXIT_RUN_FAILED, guarded
from mplang.cli.hostrun import host_options, json_out, make_plan, name_values, run_host

if TYPE_CHECKING:
    from mplang.host.session import AsyncController, CallResult


@click.command("call", short_help="Start a program on a device by its name.")
@click.argument("name")
@host_options
@click.option("--set", "settings", multiple=True, metavar="NAME=VALUE",
              help="Write a declared variable before the call (repeatable).")
@click.option("--wait", is_flag=True, help="Wait until the program ends, then report.")
@click.option("--timeout", type=click.FloatRange(min=0), default=None, metavar="S",
              help="With --wait: give up after S seconds (exit 20) [default: no limit].")
@click.pass_context
@guarded
def command(ctx: click.Context, /, name: str, settings: tuple[str, ...], wait: bool,
            timeout: float | None, no_check: bool, as_json: bool, werror: bool,
            **kw: Any) -> None:
    """Call program NAME (its declared name, or MPn) on a device over Modbus TCP or RTU.

    First the build manifest is read from the device and compared with the build of FILE...
    (.mp sources, or one image or `mpc export --format json` file; default: the project's
    sources): a device holding another build, or none, is refused with exit 16 before
    anything is written (--no-check skips this). Then the --set variables are written, in
    the device's word order, and the program is started (holding register 8). With --wait,
    the declared variables the program writes are printed when it ends; an execution error
    (input registers 115-119) is reported at its source line with its run-time code, exit 5.
    Exit 20: the program did not end within --timeout.

    A CSIM (--target csim, --serial): its program listing (ULP) is compared with the build,
    the program started with G $LABEL, --wait asks ?ST, and an error (?ERR) is reported
    without a source line: the CSIM does not say where it stopped."""
    if timeout is not None and not wait:
        raise click.UsageError("--timeout S applies to --wait: give both, or neither")
    values = name_values(settings, "--set")
    plan = make_plan(ctx, {**kw, "werror": werror})

    async def work(controller: AsyncController) -> CallResult:
        program = controller.view.program(name)  # an unknown name writes nothing
        await controller.write_vars(values)
        return await controller.call_result(program.device_name, wait, timeout)

    result = run_host(plan, not no_check, werror, work)
    if result.note:
        click.echo(f"mpc: note: {result.note}", err=True)
    if as_json:
        json_out(result.to_json())
    else:
        _print(result, wait)
    sys.exit(EXIT_RUN_FAILED if result.error is not None else EXIT_OK)


def _print(result: CallResult, waited: bool) -> None:
    """The text output: what was called, then (with --wait) the time, the variables, and
    the error at its source line on standard error."""
    program = result.program
    title = f"{program.device_name} {program.name}".rstrip()
    if not waited:
        click.echo(f"{title} started (build {result.build_id})")
        return
    state = "failed" if result.error is not None else "ended"
    click.echo(f"{title} {state} after {result.time_ms:g} ms (build {result.build_id})")
    for var, value in result.vars.items():
        click.echo(f"  {var} = {value}")
    if result.error is not None:
        click.echo(str(result.error), err=True)
