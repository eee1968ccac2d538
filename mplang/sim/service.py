"""`mpc sim`: a virtual M8194H served over Modbus TCP and/or RTU until told to stop.

The library entry point is `serve`; the CLI only parses options and prints. Macro memory
(the device's FRAM) can live in a file: it is loaded at start and written after every
successful download and at the end, so a restart keeps the programs as the device does.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mplang.compiler import BuildResult
from mplang.modbus import DeviceFace, Server, SimClock, serve_rtu, serve_tcp, stop
from mplang.sim.controller import DeviceBusy, VirtualController
from mplang.sim.ptylink import PtyLink

INIT_SETTLE_S = 10.0  # simulated seconds preload allows the init frames to take effect


class ServiceError(Exception):
    """The simulator cannot start as asked; `kind` is "memory" (the macro memory file),
    "transport" (a port that cannot be opened) or "program" (the build does not load: a
    program, the init frames or the trigger table refused)."""

    def __init__(self, message: str, kind: str = "transport") -> None:
        super().__init__(message)
        self.kind = kind


@dataclass
class SimOptions:
    tcp: tuple[str, int] | None = ("127.0.0.1", 1502)
    serial: str | None = None  # a serial device path, or "pty" for a linked pty pair
    unit: int = 1
    baudrate: int = 115200
    parity: str = "N"
    stopbits: int = 1
    speed: float = 1.0
    memory: Path | None = None
    duration: float | None = None  # stop by itself after this many wall seconds
    verbose: bool = False


@dataclass
class Endpoints:
    """Where the running simulator can be reached (filled in as the servers start)."""

    tcp: tuple[str, int] | None = None
    serial: str | None = None


def load_memory(controller: VirtualController, path: Path) -> None:
    try:
        controller.restore(path)
    except OSError as exc:
        raise ServiceError(f"{path}: cannot read macro memory: {exc.strerror or exc}",
                           "memory") from None
    except ValueError as exc:
        raise ServiceError(f"{path}: not a macro memory file written by mpc sim: {exc}",
                           "memory") from None


def preload(controller: VirtualController, build: BuildResult) -> None:
    """Download a build into the controller, as `mpc flash` would: the programs, then the
    initial table (image["init"]: its frames go through the sub-function window like a
    Modbus write, and the controller runs until the table is loaded), then the FRnet DI
    trigger table (image["triggers"], which the vendor utility would send), enabled if the
    image says so. Images without "init" or "triggers" load their programs only."""
    for program in build.programs:
        error = controller.load_frames(program.program.kind, program.placement.slot,
                                       program.frames)
        if error is not None:
            raise ServiceError(f"the virtual controller refused {program.program.label}: "
                               f"download error {error.code:#04x} at line {error.line}",
                               "program")
    image = build.image()
    if image.get("init") is not None:
        _preload_init(controller, image["init"])
    if image.get("triggers") is not None:
        _preload_triggers(controller, image["triggers"])


def _preload_init(controller: VirtualController, init: object) -> None:
    """Write the INIT frames at register 8000 and let the device run them (a full FIFO is
    waited out, as a host retries after exception 0x06)."""
    frames = init.get("frames") if isinstance(init, dict) else None
    if not isinstance(frames, list):
        raise ServiceError("image \"init\" must be an object with a \"frames\" list", "program")
    for index, frame in enumerate(frames):
        if not isinstance(frame, list) or not frame or not all(
                isinstance(w, int) and not isinstance(w, bool) and 0 <= w <= 0xFFFF
                for w in frame):
            raise ServiceError(f"init frame {index}: {frame!r} is not a list of 16-bit "
                               "register values", "program")
        while True:
            try:
                cause = controller.write_subfunction(frame)
            except DeviceBusy:  # let the device work off one command time, then retry
                controller.advance(controller.clock + controller.rtc_time)
                continue
            break
        if cause:
            reason = controller.profile.illegal_function_causes.get(cause, "unknown cause")
            raise ServiceError(f"the virtual controller refused init frame {index} "
                               f"{[f'{w:#06x}' for w in frame]}: cause {cause:#04x} "
                               f"({reason})", "program")
    controller.advance(controller.clock + INIT_SETTLE_S, until_idle=True)


def _preload_triggers(controller: VirtualController, triggers: object) -> None:
    if not isinstance(triggers, dict) or not isinstance(triggers.get("enabled", False), bool):
        raise ServiceError("image \"triggers\" must be an object with \"entries\" and a "
                           "true/false \"enabled\"", "program")
    try:
        controller.load_trigger_table(triggers.get("entries", []))
    except ValueError as exc:
        raise ServiceError(f"the trigger table: {exc}", "program") from None
    if triggers.get("enabled", False):
        controller.set_triggering(True)


async def serve(options: SimOptions, controller: VirtualController,
                announce: Callable[[str], None],
                stop_event: asyncio.Event | None = None,
                endpoints: Endpoints | None = None) -> None:
    """Serve `controller` until `stop_event` is set or `options.duration` passes."""
    if not options.verbose:
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    stop_event = stop_event or asyncio.Event()
    endpoints = endpoints if endpoints is not None else Endpoints()
    face = DeviceFace(controller, SimClock(options.speed, origin_sim=controller.clock))
    servers: list[Server] = []
    link: PtyLink | None = None
    saved = controller.memory_version
    try:
        if options.tcp is not None:
            host, port = options.tcp
            try:
                tcp_server, bound = await serve_tcp(face, host, port)
            except (OSError, RuntimeError) as exc:
                raise ServiceError(f"cannot listen on {host}:{port}: {exc}") from None
            servers.append(tcp_server)
            endpoints.tcp = (host, bound)
            announce(f"Modbus TCP on {host}:{bound} (any unit id)")
        if options.serial is not None:
            port_name = options.serial
            if port_name == "pty":
                link = PtyLink()
                port_name = link.device_end
            try:
                servers.append(await serve_rtu(face, port_name, options.unit, options.baudrate,
                                               options.parity, options.stopbits))
            except (OSError, RuntimeError) as exc:
                raise ServiceError(f"cannot open serial port {port_name}: {exc}") from None
            endpoints.serial = link.client_end if link else port_name
            settings = f"{options.baudrate} 8{options.parity}{options.stopbits}"
            announce(f"Modbus RTU on {endpoints.serial} (unit {options.unit}, {settings})")
        loop = asyncio.get_running_loop()
        deadline = None if options.duration is None else loop.time() + options.duration
        while not stop_event.is_set():
            timeout = 0.05 if deadline is None else max(0.0, min(0.05, deadline - loop.time()))
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop_event.wait(), timeout)
            face.catch_up()
            if options.verbose:
                while controller.log:
                    announce(controller.log.popleft())
            if options.memory is not None and controller.memory_version != saved:
                save_memory(controller, options.memory)
                saved = controller.memory_version
            if deadline is not None and loop.time() >= deadline:
                break
    finally:
        for server in servers:
            await stop(server)
        if link is not None:
            link.close()
        if options.memory is not None and controller.memory_version != saved:
            save_memory(controller, options.memory)


def save_memory(controller: VirtualController, path: Path) -> None:
    try:
        controller.save(path)
    except OSError as exc:
        raise ServiceError(f"{path}: cannot write macro memory: {exc.strerror or exc}",
                           "memory") from None
