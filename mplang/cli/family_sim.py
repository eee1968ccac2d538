"""`mpc sim` for the other controller families: a virtual CSIM on a serial line (or a pty
pair), and the reason there is no FATEK FBs-PLC service.

The CSIM speaks RS232 ASCII (`mplang.csim.device`), not Modbus: one serial line, one host.
`--serial pty` makes a linked pseudo-terminal pair (`mplang.family.ptylink.PtyLink`), serves
the device end and prints the end to open, as the M8194H's `mpc sim --serial pty` does.
"""

from __future__ import annotations

import importlib
import signal
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from types import FrameType

import click
import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.cli.common import EXIT_RUN_FAILED, EXIT_TRANSPORT, BuildSetup, report
from mplang.cli.families import Selection, refuse_m8194h_options
from mplang.csim import CsimProgram
from mplang.csim.device import CsimServer, Reply, VirtualCsim
from mplang.family.ptylink import PtyLink


@dataclass(frozen=True)
class SimRequest:
    """The `mpc sim` options a family service uses."""

    tcp_given: bool
    serial: str | None
    baud: int
    parity: str
    stopbits: int
    speed: float
    duration: float | None
    verbose: bool
    m8194h_options: Mapping[str, bool]  # option -> given on the command line


def serve_family(selection: Selection, setup: BuildSetup, request: SimRequest) -> None:
    """Serve the family's virtual controller until interrupted (or --duration), or refuse."""
    family = selection.family
    assert family is not None
    if not family.TRANSPORTS:
        target = selection.target or family.TARGETS[0]
        raise click.UsageError(
            f"there is no {selection.describe} device to serve: {family.NO_TRANSPORT}, so "
            f"nothing would talk to it. Run a table on the virtual PLC with `mpc run --target "
            f"{target} FILE` (or draw it with mpc plot)")
    if family is not importlib.import_module("mplang.csim"):
        raise click.UsageError(f"mpc sim has no service for {selection.describe}")
    if request.tcp_given:
        raise click.UsageError("a CSIM speaks RS232 ASCII, not Modbus TCP: serve it with "
                               "--serial PORT or --serial pty")
    if request.serial is None:
        raise click.UsageError("a CSIM is served on a serial line: give --serial PORT, or "
                               "--serial pty for a linked pseudo-terminal pair")
    refuse_m8194h_options(selection, request.m8194h_options)
    device = VirtualCsim(time_scale=request.speed)
    if selection.paths:
        _preload(device, selection, setup)
    _serve(device, request)


def _preload(device: VirtualCsim, selection: Selection, setup: BuildSetup) -> None:
    """Build FILE... and store the program as a download would; exit 5 if refused."""
    build = selection.build(setup.options)
    code = report(build, setup.werror)
    if code:
        sys.exit(code)
    programs = [p for p in build.programs if isinstance(p, CsimProgram)]
    if len(programs) != 1:
        raise click.UsageError(f"a CSIM holds one program, and FILE... make {len(programs)}: "
                               "give one .csim listing, or .mp sources")
    program = programs[0]
    refused = device.preload(program.lines)
    if refused is not None:
        text, reply = refused
        click.echo(f"mpc sim: the virtual CSIM refused {text!r} of {program.source}: "
                   f"{reply.status}", err=True)
        sys.exit(EXIT_RUN_FAILED)
    click.echo(f"mpc sim: program {program.name} ({len(program.lines)} line(s)) downloaded")


def _serve(device: VirtualCsim, request: SimRequest) -> None:
    """Serve until stopped; exit 6 if the serial line cannot be opened or fails."""
    assert request.serial is not None

    def tell(line: str, reply: Reply) -> None:
        click.echo(f"mpc sim: {line!r} -> {'; '.join([*reply.data, reply.status])}")

    link = PtyLink() if request.serial == "pty" else None
    port = link.device_end if link is not None else request.serial
    server = CsimServer(port, baudrate=request.baud, parity=request.parity,
                        stopbits=request.stopbits, device=device,
                        on_line=tell if request.verbose else None)
    try:
        try:
            server.start()
        except (serial.SerialException, OSError, ValueError) as exc:
            click.echo(f"mpc sim: cannot open serial port {port}: {exc}", err=True)
            sys.exit(EXIT_TRANSPORT)
        shown = link.client_end if link is not None else port
        click.echo(f"mpc sim: CSIM RS232 on {shown} ({request.baud} 8{request.parity}"
                   f"{request.stopbits})")
        failure = _wait(server, request.duration)
    finally:
        server.stop()
        if link is not None:
            link.close()
    if failure is not None:
        click.echo(f"mpc sim: serial line {port} failed: {failure}", err=True)
        sys.exit(EXIT_TRANSPORT)
    click.echo("mpc sim: stopped")


def _wait(server: CsimServer, duration: float | None) -> str | None:
    """Until Ctrl-C, SIGTERM or the end of `duration`; the server's failure, if any."""
    stop = threading.Event()

    def on_signal(_number: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    deadline = None if duration is None else time.monotonic() + duration
    try:
        while not stop.is_set():
            if server.failure is not None:
                return server.failure
            if deadline is not None and time.monotonic() >= deadline:
                break
            stop.wait(0.05 if deadline is None else
                      max(0.0, min(0.05, deadline - time.monotonic())))
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return server.failure
