"""`mpc sim`: serve the virtual device of the selected family (`Family.serve`): an M8194H
over Modbus TCP and/or RTU, a CSIM on a serial line; a family without one says why."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_NO_INPUT,
    EXIT_RUN_FAILED,
    EXIT_TRANSPORT,
    BuildSetup,
    build_options,
    expand_inputs,
    guarded,
    machine_option,
    parse_host_port,
    with_common,
    with_serial_line,
)
from mplang.cli.families import build_checked, machine_for, refuse_options, select
from mplang.cli.shell import complete_paths
from mplang.tools.monitor import DEFAULT_PORT


@click.command("sim", short_help="Serve a virtual M8194H over Modbus TCP and/or RTU.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--tcp", callback=parse_host_port, default=None, metavar="[HOST:]PORT",
              help="Serve Modbus TCP here: HOST:PORT, PORT (a bare number is a port, on "
              "127.0.0.1) or HOST (port 1502); port 0: any free port [default without "
              "--serial: 127.0.0.1:1502].")
@click.option("--serial", default=None, metavar="PORT|pty",
              help="Serve Modbus RTU (a CSIM: its RS232 protocol) on this serial device; "
              "'pty' makes a linked pseudo-terminal pair and prints the end to open.")
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="RTU slave address.")
@with_serial_line
@click.option("--speed", type=click.FloatRange(min=0.0001, max=10000), default=1.0,
              show_default=True, help="Simulated seconds per wall second.")
@click.option("--memory", type=click.Path(path_type=Path), default=None,
              help="Macro memory file: loaded at start, written after every download "
              "(with --devices: a directory of them).")
@click.option("--devices", type=click.IntRange(1, 1000), default=1, show_default=True,
              help="Serve this many virtual M8194H from this process over Modbus TCP, on "
              "consecutive ports from --tcp's (port 0: any free port each); --memory then "
              "names a directory with one memory file per device (device-K.json).")
@click.option("--duration", type=click.FloatRange(min=0), default=None,
              help="Stop after this many seconds [default: run until interrupted].")
@click.option("-v", "--verbose", is_flag=True, help="Print what the device does.")
@click.option("--monitor", "monitor_port", type=click.IntRange(0, 65535), default=None,
              is_flag=False, flag_value=DEFAULT_PORT, metavar="[P]",
              help=f"Serve the live dashboard of the device on http://127.0.0.1:P/ "
              f"[P: {DEFAULT_PORT}] (docs/monitor.md); it watches over Modbus TCP.")
@machine_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str, speed: float,
            memory: Path | None, devices: int, duration: float | None, verbose: bool,
            monitor_port: int | None, machine_file: Path | None, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Serve a virtual M8194H over Modbus TCP and/or RTU (FILE...: programs to preload).

    With --target csim (or a .csim FILE) a virtual CSIM answers its RS232 ASCII protocol on
    --serial PORT|pty instead. FATEK FBs-PLC tables have no device service (mpc run runs
    them)."""
    from mplang.family.face import ServeRequest, ServiceError

    def given(name: str) -> bool:
        source = ctx.get_parameter_source(name)
        return source is not None and source is not click.core.ParameterSource.DEFAULT

    if devices == 1 and memory is not None and memory.is_dir():
        raise click.BadParameter(f"File {str(memory)!r} is a directory.",
                                 param_hint="'--memory'")
    selection = select(expand_inputs(files) if files else [], target, given("target"))
    family = selection.family
    if family.serve is None:
        raise click.UsageError(
            f"there is no {selection.describe} device to serve: {family.NO_TRANSPORT}, so "
            f"nothing would talk to it. Run it on the virtual controller with `mpc run "
            f"--target {selection.target or family.TARGETS[0]} FILE` (or draw it with "
            "mpc plot)")
    refuse_options(selection, {"--unit": given("unit"), "--memory": given("memory"),
                               "--word-order": given("word_order"),
                               "--devices": given("devices")}, "SERVE_OPTIONS")
    request = ServeRequest(
        tcp=tcp, serial=serial, unit=unit, baud=baud, parity=parity, stopbits=int(stopbits),
        speed=speed, memory=memory, duration=duration, verbose=verbose,
        word_order=int(word_order) if word_order is not None else None,
        describe=selection.describe, machine=machine_for(selection, machine_file, None),
        devices=devices)
    build = None
    if files:
        setup = BuildSetup(selection.paths, build_options(
            target, word_order, temp_vars, allow_outside_includes), werror, None)
        build = build_checked(selection, setup)
    if monitor_port is not None:
        from mplang.cli.commands.monitor import dashboard, refuse_family, require_aiohttp

        if family.watch is None:
            refuse_family(family, "mpc sim --monitor")
        require_aiohttp("mpc sim --monitor")
        if serial is not None and tcp is None:
            raise click.UsageError("--monitor watches the device over Modbus TCP: give --tcp "
                                   "as well as --serial")
        request = request.replace(companion=dashboard(family, build, monitor_port))
    try:
        family.serve(build, request, lambda text: click.echo(f"mpc sim: {text}"))
    except ServiceError as exc:
        if exc.kind == "usage":
            raise click.UsageError(str(exc)) from None
        style.error(str(exc))
        sys.exit({"memory": EXIT_NO_INPUT, "refused": EXIT_RUN_FAILED}.get(exc.kind,
                                                                           EXIT_TRANSPORT))
    click.echo("mpc sim: stopped")
