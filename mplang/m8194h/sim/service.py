"""`mpc sim`: a virtual M8194H served over Modbus TCP and/or RTU until told to stop.

The library entry point is `serve`; the CLI only parses options and prints. Macro memory
(the device's FRAM: programs, initial and trigger tables, machine data) can live in a file:
it is loaded at start and written by every request that changes it, before that request is
answered (`MemoryFile`), so a restart keeps it as the device does: once the download status
says a program is stored, it is in the file. `serve_fleet` serves many controllers from one
process, each on its own TCP port (consecutive from the one asked for) with its own memory
file (`memory_path`), so a fleet of devices can be flashed and tested on one machine (`mpc sim
--devices N`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mplang.family.face import Companion
from mplang.family.ptylink import PtyLink
from mplang.lang.limits import read_json_file
from mplang.m8194h.modbus_server import DeviceFace, Server, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import ServiceError as ServiceError
from mplang.m8194h.sim.preload import preload as preload  # re-exported: the service API


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
    companion: Companion | None = None  # served beside the device once TCP listens
    devices: int = 1  # `serve_fleet`: this many controllers on consecutive TCP ports


@dataclass
class Endpoints:
    """Where the running simulator can be reached (filled in as the servers start)."""

    tcp: tuple[str, int] | None = None
    serial: str | None = None


def load_memory(controller: VirtualController, path: Path) -> None:
    try:
        read_json_file(path)  # size and depth bounded first
        controller.restore(path)
    except OSError as exc:
        raise ServiceError(f"{path}: cannot read macro memory: {exc.strerror or exc}",
                           "memory") from None
    except ValueError as exc:
        raise ServiceError(f"{path}: not a macro memory file written by mpc sim: {exc}",
                           "memory") from None


class MemoryFile:
    """A controller's memory file (`mpc sim --memory`), written as the device's FRAM is: by
    the request that changed the memory, before it is answered (`DeviceFace.persist`), and
    after changes made between requests (a running program's machine data) at the next tick
    and at the end. A failed write is raised by the next `flush`: the simulator stops rather
    than serve a memory it cannot keep."""

    def __init__(self, controller: VirtualController, path: Path) -> None:
        self.controller = controller
        self.path = path
        self.saved = controller.memory_version
        self.error: ServiceError | None = None

    def __call__(self) -> bool:
        """Store now (the face's hook): False, and the error kept, if it cannot be written."""
        try:
            save_memory(self.controller, self.path)
        except ServiceError as exc:
            self.error = exc
            return False
        self.saved = self.controller.memory_version
        return True

    def flush(self) -> None:
        """Store what changed since the last write; raise the error of a failed write."""
        if self.error is None and self.controller.memory_version != self.saved:
            self()
        if self.error is not None:
            raise self.error


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
    memory = None if options.memory is None else MemoryFile(controller, options.memory)
    face.persist = memory
    companions = contextlib.AsyncExitStack()
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
            if options.companion is not None:
                await companions.enter_async_context(options.companion(host, bound))
        if options.serial is not None:
            port_name = options.serial
            try:  # PtyLink raises OSError where there are no ptys (Windows)
                if port_name == "pty":
                    link = PtyLink()
                    port_name = link.device_end
                servers.append(await serve_rtu(face, port_name, options.unit, options.baudrate,
                                               options.parity, options.stopbits))
            except (OSError, RuntimeError) as exc:
                raise ServiceError(f"cannot open serial port {port_name}: {exc}") from None
            endpoints.serial = link.client_end if link else port_name
            settings = f"{options.baudrate} 8{options.parity}{options.stopbits}"
            announce(f"Modbus RTU on {endpoints.serial} (unit {options.unit}, {settings})")

        def tick() -> None:
            face.catch_up()
            if options.verbose:
                while controller.log:
                    announce(controller.log.popleft())
            if memory is not None:
                memory.flush()

        await _ticking(tick, stop_event, options.duration)
    finally:
        if options.verbose:  # what the device did since the last tick, before it stops
            while controller.log:
                announce(controller.log.popleft())
        await companions.aclose()
        for server in servers:
            await stop(server)
        if link is not None:
            link.close()
        if memory is not None:
            memory.flush()


async def _ticking(tick: Callable[[], None], stop_event: asyncio.Event,
                   duration: float | None) -> None:
    """Call `tick` every 50 ms (the devices catch up with the wall clock, their logs and
    memory files follow) until `stop_event` or the end of `duration` seconds."""
    loop = asyncio.get_running_loop()
    deadline = None if duration is None else loop.time() + duration
    while not stop_event.is_set():
        timeout = 0.05 if deadline is None else max(0.0, min(0.05, deadline - loop.time()))
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop_event.wait(), timeout)
        tick()
        if deadline is not None and loop.time() >= deadline:
            break


def save_memory(controller: VirtualController, path: Path) -> None:
    try:
        controller.save(path)
    except OSError as exc:
        raise ServiceError(f"{path}: cannot write macro memory: {exc.strerror or exc}",
                           "memory") from None


def memory_path(memory: Path | None, device: int, devices: int) -> Path | None:
    """Device `device`'s (1..`devices`) memory file: `memory` itself for one device; for a
    fleet `memory` is a directory holding `device-K.json` per device."""
    if memory is None or devices == 1:
        return memory
    return memory / f"device-{device}.json"


async def serve_fleet(options: SimOptions, controllers: list[VirtualController],
                      announce: Callable[[str], None],
                      stop_event: asyncio.Event | None = None,
                      ports: list[int] | None = None) -> None:
    """Serve every controller of `controllers` over Modbus TCP on `options.tcp`'s host, the
    first on its port and each next one on the port after (port 0: any free port for each),
    until `stop_event` is set or `options.duration` passes. `ports` (if given) receives the
    ports bound, in device order, as they are. Each device's memory is saved to its own file
    (`memory_path`) after every change and at the end."""
    if not options.verbose:
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    assert options.tcp is not None
    stop_event = stop_event or asyncio.Event()
    ports = ports if ports is not None else []
    host, first = options.tcp
    count = len(controllers)
    faces = [DeviceFace(c, SimClock(options.speed, origin_sim=c.clock)) for c in controllers]
    memories: list[MemoryFile] = []
    for k, (controller, face) in enumerate(zip(controllers, faces, strict=True)):
        path = memory_path(options.memory, k + 1, count)
        if path is not None:
            memories.append(MemoryFile(controller, path))
            face.persist = memories[-1]
    servers: list[Server] = []

    def save_changed() -> None:
        for memory in memories:
            memory.flush()

    try:
        for k, face in enumerate(faces):
            port = first + k if first else 0
            try:
                listening, bound = await serve_tcp(face, host, port)
            except (OSError, RuntimeError) as exc:
                raise ServiceError(f"cannot listen on {host}:{port} (device {k + 1} of "
                                   f"{count}): {exc}") from None
            servers.append(listening)
            ports.append(bound)
            announce(f"Modbus TCP on {host}:{bound} (device {k + 1} of {count}, any unit id)")

        def tick() -> None:
            for k, face in enumerate(faces):
                face.catch_up()
                if options.verbose:
                    while face.controller.log:
                        announce(f"device {k + 1}: {face.controller.log.popleft()}")
            save_changed()

        await _ticking(tick, stop_event, options.duration)
    finally:
        for server in servers:
            await stop(server)
        save_changed()
