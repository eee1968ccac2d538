"""`mpc sim` for the M8194H: a virtual controller served over Modbus TCP and/or RTU until
stopped, with its macro memory kept in a file and the build (if any) downloaded first, as
`mpc flash` would."""

from __future__ import annotations

import asyncio
import re
from collections.abc import Awaitable, Callable

from mplang.family.face import FamilyBuild, Say, ServeRequest, ServiceError
from mplang.family.stopsignals import on_stop_signals
from mplang.m8194h.image import BuildResult
from mplang.m8194h.machine import MachineSetup, apply_machine
from mplang.m8194h.run import declared_variables, source_place
from mplang.m8194h.sim import service
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.failure import Place

DEFAULT_TCP = ("127.0.0.1", 1502)
"""Where `mpc sim` listens when given neither --tcp nor --serial."""


_PROGRAM = re.compile(r"\b(MP|ISR)(\d+)( line (\d+))?\b")
_VARIABLE = re.compile(r"\bVAR(\d+)\b")


class LogNames:
    """What `mpc sim -v` prints in the sources' words when it was started with them: a
    program slot with its name (`MP100 job`), a slot line with its source line too
    (`MP100 job line 4 (job.mp:12)`), a declared variable by its name with the number
    beside it (`rows_done (VAR400)`)."""

    def __init__(self, build: BuildResult) -> None:
        self.build = build
        self.programs = {(image.program.kind.upper(), image.placement.slot): image.program.name
                         for image in build.programs if image.program.name}
        self.variables = {index: label for label, index in declared_variables(build)}

    def __call__(self, line: str) -> str:
        return _VARIABLE.sub(self._variable, _PROGRAM.sub(self._program, line))

    def _program(self, match: re.Match[str]) -> str:
        kind, slot = match.group(1), int(match.group(2))
        name = self.programs.get((kind, slot))
        text = f"{kind}{slot}" + (f" {name}" if name else "")
        if match.group(4) is None:
            return text
        place = source_place(self.build, Place(kind.lower(), slot, int(match.group(4))))
        where = f" ({place.file}:{place.line})" if place.file and place.line else ""
        return f"{text} line {match.group(4)}{where}"

    def _variable(self, match: re.Match[str]) -> str:
        return self.variables.get(int(match.group(1)), match.group(0))


def named(say: Say, names: LogNames) -> Say:
    """`say`, every line in the sources' words."""
    return lambda text: say(names(text))


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
            say = named(say, LogNames(build))
            service.preload(controller, build)
            say(f"{len(build.programs)} program(s) downloaded")
            if memory is not None:
                service.save_memory(controller, memory)
        if request.machine is not None:  # what `load_machine` read (docs/machine.md)
            assert isinstance(request.machine, MachineSetup)
            apply_machine(controller, request.machine)
            say(f"machine {request.machine.path}")
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "refused", str(exc)) from None
    options = service.SimOptions(
        tcp=request.tcp if request.tcp is not None or request.serial is not None
        else DEFAULT_TCP, serial=request.serial, unit=request.unit, baudrate=request.baud,
        parity=request.parity, stopbits=request.stopbits, speed=request.speed, memory=memory,
        duration=request.duration, verbose=request.verbose, companion=request.companion)

    _until_stopped(lambda stop_event: service.serve(options, controller, say, stop_event))


def serve_devices(build: FamilyBuild | None, request: ServeRequest, say: Say) -> None:
    """`mpc sim --devices N`: N controllers from this process on consecutive TCP ports, each
    with its memory file in the `--memory` directory (`service.memory_path`), each loaded and
    given the build as one device is."""
    if request.serial is not None:
        raise ServiceError("usage", "--devices serves Modbus TCP only (one RTU line is one "
                           "device here): leave out --serial, or serve one device")
    if request.companion is not None:
        raise ServiceError("usage", "--monitor watches one device: serve the fleet without "
                           "it and watch a device with `mpc monitor --tcp HOST:PORT`")
    count = request.devices
    first = (request.tcp or DEFAULT_TCP)[1]
    if first and first + count - 1 > 65535:
        raise ServiceError("usage", f"--devices {count} from port {first} needs ports "
                           f"{first}-{first + count - 1}, past 65535, the last TCP port: "
                           f"start at {65536 - count} at most, or at 0 (any free ports)")
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
            if request.machine is not None:  # every device drives the same machine
                assert isinstance(request.machine, MachineSetup)
                apply_machine(controller, request.machine)
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

    _until_stopped(lambda stop_event: service.serve_fleet(options, controllers, say,
                                                          stop_event))


def _until_stopped(serving: Callable[[asyncio.Event], Awaitable[None]]) -> None:
    """Run a service until Ctrl-C, SIGTERM or its own end; its failures as `ServiceError`s
    ("memory" for a memory file, "transport" for the ports)."""

    async def main_task() -> None:
        stop_event = asyncio.Event()
        with on_stop_signals(stop_event.set):
            await serving(stop_event)

    try:
        asyncio.run(main_task())
    except service.ServiceError as exc:
        raise ServiceError("memory" if exc.kind == "memory" else "transport", str(exc)) from None
