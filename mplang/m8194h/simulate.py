"""`mpc sim` for the M8194H: a virtual controller served over Modbus TCP and/or RTU until
stopped, with its macro memory kept in a file and the build (if any) downloaded first, as
`mpc flash` would."""

from __future__ import annotations

import asyncio
import signal

from mplang.family.face import FamilyBuild, Say, ServeRequest, ServiceError
from mplang.m8194h.image import BuildResult
from mplang.m8194h.sim import service
from mplang.m8194h.sim.controller import VirtualController

DEFAULT_TCP = ("127.0.0.1", 1502)
"""Where `mpc sim` listens when given neither --tcp nor --serial."""


def serve(build: FamilyBuild | None, request: ServeRequest, say: Say) -> None:
    """Load the memory file, download `build`, then serve until Ctrl-C, SIGTERM or
    `request.duration`. Every failure is a `ServiceError`: "memory" for the memory file,
    "refused" when the controller refuses the build, "transport" for the ports."""
    if request.devices > 1:
        serve_devices(build, request, say)
        return
    controller = VirtualController(word_order=request.word_order or 0)
    memory = request.memory
    try:
        if memory is not None and memory.exists():
            service.load_memory(controller, memory)
            say(f"macro memory {memory}: {len(controller.tables)} program(s)")
        if build is not None:
            assert isinstance(build, BuildResult)
            service.preload(controller, build)
            say(f"{len(build.programs)} program(s) downloaded")
            if memory is not None:
                service.save_memory(controller, memory)
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "refused", str(exc)) from None
    options = service.SimOptions(
        tcp=request.tcp if request.tcp is not None or request.serial is not None
        else DEFAULT_TCP, serial=request.serial, unit=request.unit, baudrate=request.baud,
        parity=request.parity, stopbits=request.stopbits, speed=request.speed, memory=memory,
        duration=request.duration, verbose=request.verbose)

    async def main_task() -> None:
        stop_event = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop_event.set)
        await service.serve(options, controller, say, stop_event)

    try:
        asyncio.run(main_task())
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "transport", str(exc)) from None


def serve_devices(build: FamilyBuild | None, request: ServeRequest, say: Say) -> None:
    """`mpc sim --devices N`: N controllers from this process on consecutive TCP ports, each
    with its memory file in the `--memory` directory (`service.memory_path`), each loaded and
    given the build as one device is."""
    if request.serial is not None:
        raise ServiceError("usage", "--devices serves Modbus TCP only (one RTU line is one "
                           "device here): leave out --serial, or serve one device")
    count = request.devices
    if request.memory is not None:
        if request.memory.exists() and not request.memory.is_dir():
            raise ServiceError("usage", f"--memory {request.memory}: with --devices it names "
                               "a directory (one memory file per device), not a file")
        try:
            request.memory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ServiceError("memory", f"{request.memory}: cannot make the memory "
                               f"directory: {exc.strerror or exc}") from None
    controllers = []
    try:
        for k in range(1, count + 1):
            controller = VirtualController(word_order=request.word_order or 0)
            memory = service.memory_path(request.memory, k, count)
            if memory is not None and memory.exists():
                service.load_memory(controller, memory)
            if build is not None:
                assert isinstance(build, BuildResult)
                service.preload(controller, build)
                if memory is not None:
                    service.save_memory(controller, memory)
            controllers.append(controller)
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "refused", str(exc)) from None
    kept = sum(1 for c in controllers if c.tables)
    say(f"{count} devices" + (f", macro memory in {request.memory}/device-K.json"
                              if request.memory is not None else "")
        + (f", {len(build.programs)} program(s) downloaded to each"
           if isinstance(build, BuildResult) else f" ({kept} with programs)"))
    options = service.SimOptions(
        tcp=request.tcp or DEFAULT_TCP, speed=request.speed, memory=request.memory,
        duration=request.duration, verbose=request.verbose, devices=count)

    async def main_task() -> None:
        stop_event = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop_event.set)
        await service.serve_fleet(options, controllers, say, stop_event)

    try:
        asyncio.run(main_task())
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "transport", str(exc)) from None
