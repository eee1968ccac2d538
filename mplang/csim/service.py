"""`mpc sim` for the CSIM: a virtual CSIM on a serial line (or a pty pair) until stopped.

The CSIM speaks RS232 ASCII (`mplang.csim.device`), not Modbus: one serial line, one host.
`--serial pty` makes a linked pseudo-terminal pair (`mplang.family.ptylink.PtyLink`), serves
the device end and reports the end to open, as the M8194H's `mpc sim --serial pty` does.
"""

from __future__ import annotations

import signal
import threading
import time
from types import FrameType

import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.csim.build import CsimProgram
from mplang.csim.device import CsimServer, Reply, VirtualCsim
from mplang.family.face import FamilyBuild, Say, ServeRequest, ServiceError
from mplang.family.linkfail import serial_reason
from mplang.family.ptylink import PtyLink, PtyUnavailable


def serve(build: FamilyBuild | None, request: ServeRequest, say: Say) -> None:
    """Serve a virtual CSIM holding `build`'s program (if any) until Ctrl-C, SIGTERM or
    `request.duration`; `ServiceError` when the request does not fit a CSIM, the program is
    refused, or the serial line cannot be opened or fails."""
    if request.tcp is not None:
        raise ServiceError("usage", "a CSIM speaks RS232 ASCII, not Modbus TCP: serve it with "
                           "--serial PORT or --serial pty")
    if request.serial is None:
        raise ServiceError("usage", "a CSIM is served on a serial line: give --serial PORT, "
                           "or --serial pty for a linked pseudo-terminal pair")
    device = VirtualCsim(time_scale=request.speed)
    if build is not None:
        _preload(device, build, say)
    _serve(device, request, say)


def _preload(device: VirtualCsim, build: FamilyBuild, say: Say) -> None:
    """Store the build's one program as a download would."""
    programs = [p for p in build.programs if isinstance(p, CsimProgram)]
    if len(programs) != 1:
        raise ServiceError("usage", f"a CSIM holds one program, and FILE... make "
                           f"{len(programs)}: give one .csim listing, or .mp sources")
    program = programs[0]
    refused = device.preload(program.lines)
    if refused is not None:
        text, reply = refused
        raise ServiceError("refused", f"the virtual CSIM refused {text!r} of "
                           f"{program.source}: {reply.status}")
    say(f"program {program.name} ({len(program.lines)} line(s)) downloaded")


def _serve(device: VirtualCsim, request: ServeRequest, say: Say) -> None:
    assert request.serial is not None

    def tell(line: str, reply: Reply) -> None:
        say(f"{line!r} -> {'; '.join([*reply.data, reply.status])}")

    try:
        link = PtyLink() if request.serial == "pty" else None
    except PtyUnavailable as exc:  # Windows
        raise ServiceError("transport", f"cannot open serial port pty: {exc}") from None
    port = link.device_end if link is not None else request.serial
    server = CsimServer(port, baudrate=request.baud, parity=request.parity,
                        stopbits=request.stopbits, device=device,
                        on_line=tell if request.verbose else None)
    try:
        try:
            server.start()
        except (serial.SerialException, OSError, ValueError) as exc:
            raise ServiceError("transport", f"cannot open serial port {port}: "
                               f"{serial_reason(exc)}") from None
        shown = link.client_end if link is not None else port
        say(f"CSIM RS232 on {shown} ({request.baud} 8{request.parity}{request.stopbits})")
        failure = _wait(server, request.duration)
    finally:
        server.stop()
        if link is not None:
            link.close()
    if failure is not None:
        raise ServiceError("transport", f"serial line {port} failed: {failure}")


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
