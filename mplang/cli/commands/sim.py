"""`mpc sim`: serve a virtual M8194H over Modbus TCP and/or RTU, or a virtual CSIM on a
serial line (`--target csim`, `mplang.cli.family_sim`)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli.common import (
    EXIT_NO_INPUT,
    EXIT_RUN_FAILED,
    EXIT_TRANSPORT,
    BuildSetup,
    build_options,
    expand_inputs,
    guarded,
    parse_host_port,
    report,
    with_common,
    with_serial_line,
)
from mplang.cli.families import select
from mplang.m8194h.compiler import compile_paths


@click.command("sim", short_help="Serve a virtual M8194H over Modbus TCP and/or RTU.")
@click.argument("files", nargs=-1)
@click.option("--tcp", callback=parse_host_port, default=None, metavar="HOST:PORT",
              help="Serve Modbus TCP here (port 0: any free port) [default without --serial: "
              "127.0.0.1:1502].")
@click.option("--serial", default=None, metavar="PORT|pty",
              help="Serve Modbus RTU (a CSIM: its RS232 protocol) on this serial device; "
              "'pty' makes a linked pseudo-terminal pair and prints the end to open.")
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="RTU slave address.")
@with_serial_line
@click.option("--speed", type=click.FloatRange(min=0.0001, max=10000), default=1.0,
              show_default=True, help="Simulated seconds per wall second.")
@click.option("--memory", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Macro memory file: loaded at start, written after every download.")
@click.option("--duration", type=click.FloatRange(min=0), default=None,
              help="Stop after this many seconds [default: run until interrupted].")
@click.option("-v", "--verbose", is_flag=True, help="Print what the device does.")
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str, speed: float,
            memory: Path | None, duration: float | None, verbose: bool, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Serve a virtual M8194H over Modbus TCP and/or RTU (FILE...: programs to preload).

    With --target csim (or a .csim FILE) a virtual CSIM answers its RS232 ASCII protocol on
    --serial PORT|pty instead. FATEK FBs-PLC tables have no device service (mpc run runs
    them)."""
    import asyncio
    import signal

    def given(name: str) -> bool:
        source = ctx.get_parameter_source(name)
        return source is not None and source is not click.core.ParameterSource.DEFAULT

    selection = select(expand_inputs(files) if files else [], target, given("target"))
    if selection.family is not None:
        from mplang.cli.family_sim import SimRequest, serve_family

        setup = BuildSetup(selection.paths, build_options(target, None, temp_vars,
                                                          allow_outside_includes), werror, None)
        serve_family(selection, setup, SimRequest(
            tcp_given=tcp is not None, serial=serial, baud=baud, parity=parity,
            stopbits=int(stopbits), speed=speed, duration=duration, verbose=verbose,
            m8194h_options={"--unit": given("unit"), "--memory": given("memory"),
                            "--word-order": given("word_order")}))
        return

    from mplang.m8194h.sim.controller import VirtualController
    from mplang.m8194h.sim.service import (
        ServiceError,
        SimOptions,
        load_memory,
        preload,
        save_memory,
        serve,
    )

    controller = VirtualController(word_order=int(word_order or 0))
    try:
        if memory is not None and memory.exists():
            load_memory(controller, memory)
            click.echo(f"mpc sim: macro memory {memory}: {len(controller.tables)} program(s)")
        if files:
            result = compile_paths(selection.paths, build_options(
                target, word_order, temp_vars, allow_outside_includes))
            code = report(result, werror)
            if code:
                sys.exit(code)
            preload(controller, result)
            click.echo(f"mpc sim: {len(result.programs)} program(s) downloaded")
            if memory is not None:
                save_memory(controller, memory)
    except ServiceError as exc:
        click.echo(f"mpc sim: {exc}", err=True)
        sys.exit(EXIT_NO_INPUT if exc.kind == "memory" else EXIT_RUN_FAILED)
    options = SimOptions(tcp=tcp if tcp is not None or serial is not None
                         else ("127.0.0.1", 1502),
                         serial=serial, unit=unit, baudrate=baud, parity=parity,
                         stopbits=int(stopbits), speed=speed, memory=memory,
                         duration=duration, verbose=verbose)

    async def main_task() -> None:
        stop_event = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop_event.set)
        await serve(options, controller, lambda text: click.echo(f"mpc sim: {text}"),
                    stop_event)

    try:
        asyncio.run(main_task())
    except ServiceError as exc:
        click.echo(f"mpc sim: {exc}", err=True)
        sys.exit(EXIT_NO_INPUT if exc.kind == "memory" else EXIT_TRANSPORT)
    click.echo("mpc sim: stopped")
