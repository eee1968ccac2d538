"""`mpc sim` for the M8194H: a virtual controller served over Modbus TCP and/or RTU until
stopped, with its macro memory kept in a file and the build (if any) downloaded first, as
`mpc flash` would."""

from __future__ import annotations

import asyncio
import re
import signal

from mplang.family.face import FamilyBuild, Say, ServeRequest, ServiceError
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
