"""`mpc var`: read or write a device's declared variables by name, after checking that the
device holds the build of FILE... (`mplang.host`)."""

from __future__ import annotations

import glob
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mplang.cli.common import guarded
from mplang.cli.hostrun import host_options, json_out, make_plan, name_values, run_host

if TYPE_CHECKING:
    from mplang.family.hostview import HostValue
    from mplang.host.session import AsyncController

FILE_SUFFIXES = (".mp", ".csim", ".json")


def split_arguments(arguments: tuple[str, ...]) -> tuple[list[str], list[str], list[str]]:
    """NAME (read), NAME=VALUE (write) and FILE arguments: an argument with `=` is a write;
    one that names an existing path, a glob that matches, or ends in .mp / .json is a
    file; any other is a name to read."""
    reads: list[str] = []
    writes: list[str] = []
    files: list[str] = []
    for arg in arguments:
        if "=" in arg:
            writes.append(arg)
        elif arg.lower().endswith(FILE_SUFFIXES) or Path(arg).exists() or \
                (any(ch in arg for ch in "*?[") and glob.glob(arg)):
            files.append(arg)
        else:
            reads.append(arg)
    return reads, writes, files


@click.command("var", short_help="Read or write a device's variables by name.")
@host_options
@click.pass_context
@guarded
def command(ctx: click.Context, /, files: tuple[str, ...], no_check: bool, as_json: bool,
            werror: bool, **kw: Any) -> None:
    """Read (NAME) or write (NAME=VALUE) declared variables on a device over Modbus TCP or
    RTU, by the names of the build of FILE... (.mp sources, or one image or
    `mpc export --format json` file; default: the project's sources). With no NAME, every
    declared variable is read. Values are 32-bit, in the device's word order (holding
    register 14); writes go first, then every named variable is read back. A CSIM
    (--target csim, --serial): the R variables the names became, real values (?Rk, Rk=v).

    As `mpc call`, the device's build manifest must name FILE's build, or the command is
    refused with exit 16 before anything is written (--no-check skips this); a CSIM's
    program listing (ULP) is compared instead."""
    reads, assignments, sources = split_arguments(files)
    values = name_values(tuple(assignments), "NAME=VALUE")
    plan = make_plan(ctx, {**kw, "files": tuple(sources), "werror": werror})
    shown = [*reads, *[name for name in values if name not in reads]]

    async def work(controller: AsyncController) -> list[tuple[str, str, HostValue]]:
        found = [controller.view.variable(name) for name in shown]  # all known before a write
        await controller.write_vars(values)
        read = await controller.read_vars(shown or None)
        names = {v.name: v.device_name for v in found or controller.view.variables}
        return [(name, names[name], value) for name, value in read.items()]

    rows = run_host(plan, not no_check, werror, work)
    if not rows and plan.family.PROTOCOL == "modbus":
        click.echo("mpc: note: the build declares no variables (an image JSON names none: "
                   "give the sources, or what mpc export --format json wrote)", err=True)
    elif not rows:
        click.echo("mpc: note: the build declares no variables: a .csim script has no "
                   "declarations, and a .mp build's declared variables that its programs "
                   "never use get no CSIM variable (docs/host.md#a-csim)", err=True)
    if as_json:
        json_out({name: value for name, _device, value in rows})
        return
    for name, device, value in rows:
        click.echo(f"{name} ({device}) = {value}")
