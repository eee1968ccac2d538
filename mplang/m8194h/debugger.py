"""`mpc dap` on the virtual M8194H: one MP of a build, run line by line under a debugger.

The controller calls `VirtualController.before_line` before each macro line (and each
closing line) it runs; `Session` answers True there to stop. A stop happens only where a
source line begins (the first macro line of a statement, or a program's END line), so a
statement lowered to several macro lines is one step. Source places come from the same
mapping `mpc run` uses for its findings (`RunReport.source_of`), so the debugger and the
run's error messages always name the same line.

An ISR is shown as its own stack frame on top of the program it interrupted (the device runs
it on the same stack: the MP resumes when it ends); there is one thread, the called MP.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from mplang.family.debug import Breakpoint, DebugSetupError, Item, StackEntry, Stopped
from mplang.family.face import RunSetupError
from mplang.family.run_error import RunError, SourcePlace
from mplang.ir import catalogue
from mplang.ir.lower import wrap32
from mplang.ir.macro import BVarRef, VarRef
from mplang.lang.sources import LIBRARY_PREFIX, library_files
from mplang.m8194h.image import BuildResult
from mplang.m8194h.machine import MachineError, load_machine
from mplang.m8194h.machine import apply_machine as install_machine
from mplang.m8194h.run import RunReport, pick_program, program_title
from mplang.m8194h.sim.controller import AXIS_NAMES, Frame, RunResult, VirtualController
from mplang.m8194h.sim.failure import Place
from mplang.m8194h.sim.preload import ServiceError, preload

MAX_TIME_S = 3600.0  # a program that never ends stops here (R202); above `mpc run`'s 120 s,
# so a session stepping through a long job does not run out
# The axis counters a host may set, by the command it uses (scope "rtc": sent over Modbus)
_HOST_SETS = {"LP": "RSM_SET_LP", "EP": "RSM_SET_EP"}
_DEVICE_NAME = re.compile(r"(b?)VAR(\d+)", re.IGNORECASE)
# DI status bits of an axis (input register 16+axis), as the virtual controller sets them
# (`axis_io.report`): (name, bit, active when the bit is 1)
_DI_BITS = (("LMT+", 1, True), ("LMT-", 2, True), ("EMG", 3, True), ("ALARM", 4, True),
            ("HOME", 5, False), ("NHOME", 6, False), ("IN3 level", 7, True), ("INPOS", 8, False),
            ("INDEX", 9, False))


@dataclass(frozen=True)
class _Line:
    """A macro line (or a closing line) in source terms."""

    place: SourcePlace
    starts: bool  # the first macro line of its source line: a place to stop
    column: int  # where the statement of its source line starts (1-based)


def apply_machine(controller: VirtualController, machine: Path | None) -> None:
    """Set up the simulated machine (sensors, limits, scripted inputs) from a machine file,
    or from the `[machine]` table of an mpc.toml, as `mpc run --machine` does. A file that
    cannot be used fails the launch with its reason (at its line), so a session never runs on
    a machine other than the one asked for."""
    if machine is None:
        return
    if not machine.is_file():
        raise DebugSetupError(f"machine file {machine}: no such file")
    try:
        setup = load_machine(machine, project=machine.name == "mpc.toml")
    except MachineError as exc:
        raise DebugSetupError(str(exc)) from None
    install_machine(controller, setup)


def start(build: object, call: str | None, machine: Path | None,
          max_time: float = MAX_TIME_S) -> Session:
    """The face's `debug`: load the build into a fresh controller, call the MP, stop."""
    if not isinstance(build, BuildResult):
        raise DebugSetupError("not an M8194H build")
    controller = VirtualController(word_order=build.word_order)
    try:
        preload(controller, build)
    except ServiceError as exc:
        raise DebugSetupError(str(exc)) from None
    apply_machine(controller, machine)
    try:
        slot = pick_program(build, call, build.first_source)
    except RunSetupError as exc:
        raise DebugSetupError(str(exc)) from None
    controller.call(slot)
    return Session(controller, build, slot, max_time)


class Session:
    """One called MP under the debugger (`mplang.family.debug.Debuggee`)."""

    def __init__(self, controller: VirtualController, build: BuildResult, slot: int,
                 max_time: float) -> None:
        self.controller = controller
        self.build = build
        self.report = RunReport(controller, RunResult(False, 0.0, 0), f"MP{slot}", build=build)
        self.title = program_title(build, f"MP{slot}")
        self.limit = controller.clock + max_time
        self.lines = {key: self._lines(table.kind, table.slot, len(table.lines))
                      for key, table in controller.tables.items()}
        self.breakpoints: dict[str, dict[tuple[str, int, int], list[Breakpoint]]] = {}
        self.at_points: dict[tuple[str, int, int], list[Breakpoint]] = {}
        self.entry_points: dict[tuple[str, int], Sequence[Breakpoint]] = {}
        self.data_points: dict[str, Sequence[Breakpoint]] = {}
        self._watched: dict[str, int] = {}  # each watched variable's value when last seen
        self.error: RunError | None = None
        self.ended = False
        self.finished_ok = False
        self._stop: Stopped | None = None
        self._skip: tuple[Frame, int] | None = None
        self._fresh = True  # nothing has run yet
        self._mode = "continue"
        self._depth = 0
        self._interrupted: Callable[[], bool] = lambda: False

    def _lines(self, kind: str, slot: int, count: int) -> list[_Line]:
        """Each pc of a table (and its closing line, `count`) as a source place."""
        table = self.controller.tables[(kind, slot)]
        places = [self.report.source_of(Place(kind, slot, table.lines[pc].slot_line))
                  for pc in range(count)]
        places.append(self.report.source_of(Place(kind, slot, -1)))  # the END line
        return [_Line(place, pc == 0 or pc == count or
                      (place.file, place.line) != (places[pc - 1].file, places[pc - 1].line),
                      self.column(place.file, place.line) if place.file and place.line
                      else place.column or 1)
                for pc, place in enumerate(places)]

    # ------------------------------------------------------------- the face's questions
    @property
    def time_s(self) -> float:
        return self.controller.clock

    @property
    def finished(self) -> bool:
        return self.ended

    def warnings(self) -> Sequence[str]:
        return self.report.warnings

    def files(self) -> Mapping[str, Path]:
        library = library_files()
        found: dict[str, Path] = {}
        for name in self.build.sources:
            if name.startswith(LIBRARY_PREFIX):
                entry = library.get(name.removeprefix(LIBRARY_PREFIX))
                if entry is not None:
                    found[name] = Path(str(entry))
            else:
                found[name] = Path(name).resolve()
        return found

    def stop_lines(self, file: str) -> Sequence[int]:
        return sorted({line.place.line for lines in self.lines.values() for line in lines
                       if line.starts and line.place.file == file
                       and line.place.line is not None})

    def set_breakpoints(self, file: str, points: Sequence[Breakpoint]) -> None:
        by_line: dict[int, list[Breakpoint]] = {}
        for point in points:
            by_line.setdefault(point.line, []).append(point)
        placed: dict[tuple[str, int, int], list[Breakpoint]] = {}
        for (kind, slot), lines in self.lines.items():
            for pc, line in enumerate(lines):
                if line.starts and line.place.file == file and line.place.line in by_line:
                    placed[(kind, slot, pc)] = by_line[line.place.line]
        self.breakpoints[file] = placed
        self.at_points = {key: found for table in self.breakpoints.values()
                          for key, found in table.items()}

    def lookup(self, name: str) -> int | None:
        axis, dot, counter = name.partition(".")
        if dot:
            return self._counter(axis.upper(), counter.upper())
        found = self.variable(name)
        if found is None:
            return None
        values, index = self._cell(found)
        return values[index]

    def _counter(self, axis: str, counter: str) -> int | None:
        """An axis's LP, EP or CV (pulses per second, whole) now; None for another name."""
        if axis not in AXIS_NAMES or counter not in ("LP", "EP", "CV"):
            return None
        index, now = AXIS_NAMES.index(axis), self.controller.clock
        if counter == "CV":
            return int(self.controller.motion.cv(1 << index, now))
        report = self.controller.motion.axis_report(index, now)
        return int(report.lp if counter == "LP" else report.ep)

    def variable(self, name: str) -> str | None:
        controller = self.controller
        match = _DEVICE_NAME.fullmatch(name)
        if match:
            byte, index = bool(match.group(1)), int(match.group(2))
            values = controller.bvars if byte else controller.vars
            return f"{'bVAR' if byte else 'VAR'}{index}" if index < len(values) else None
        for variable in (*self.build.variables, *self.build.aliases):
            if variable.name.lower() == name.lower() and variable.index < len(controller.vars):
                return f"VAR{variable.index}"
        return None

    def _cell(self, device_name: str) -> tuple[list[int], int]:
        """The value list and index of a device name `variable` gave."""
        if device_name.startswith("b"):
            return self.controller.bvars, int(device_name.removeprefix("bVAR"))
        return self.controller.vars, int(device_name.removeprefix("VAR"))

    def column(self, file: str, line: int) -> int:
        lines = self.build.sources.get(file, [])
        text = lines[line - 1] if 0 < line <= len(lines) else ""
        return len(text) - len(text.lstrip()) + 1 if text.strip() else 1

    def program(self, name: str) -> StackEntry | None:
        wanted = " ".join(name.split()).upper()
        for image in self.build.programs:
            kind, slot = image.program.kind, image.placement.slot
            device = f"{kind.upper()}{slot}"
            full = f"{device} {image.program.name}".upper() if image.program.name else device
            if wanted in (device, full, (image.program.name or device).upper()) \
                    and (kind, slot) in self.lines:
                place = self.lines[(kind, slot)][0]
                return StackEntry(self._name(place.place.program, kind), place.place.file,
                                  place.place.line, place.column, kind)
        return None

    def set_function_breakpoints(self, points: Mapping[str, Sequence[Breakpoint]]) -> None:
        found: dict[tuple[str, int], Sequence[Breakpoint]] = {}
        for name, placed in points.items():
            match = re.match(r"(MP|ISR)(\d+)", name)
            if match:
                found[(match.group(1).lower(), int(match.group(2)))] = placed
        self.entry_points = found

    def set_data_breakpoints(self, points: Mapping[str, Sequence[Breakpoint]]) -> None:
        self.data_points = dict(points)

    def set_value(self, path: Sequence[str], name: str, value: int) -> Item:
        if tuple(path) == ("Variables",):
            found = self.variable(name)
            if found is None:
                raise ValueError(f"no variable {name!r} in this build")
            values, index = self._cell(found)
            values[index] = value & 0xFF if found.startswith("b") else wrap32(value)
            return Item(name, str(values[index]),
                        number=found if found.lower() != name.lower() else "")
        if len(path) == 2 and path[0] == "Axes" and path[1] in AXIS_NAMES:
            axis = AXIS_NAMES.index(path[1])
            if name not in _HOST_SETS:
                raise ValueError(f"{path[1]} {name} is read only: a host sets an axis's "
                                 "logical position (LP) and encoder position (EP)")
            command = catalogue.load("m8194h").by_vendor[_HOST_SETS[name]]
            low, high = command.params[-1].min, command.params[-1].max
            if (low is not None and value < low) or (high is not None and value > high):
                raise ValueError(f"{name} {value} is out of the device's range {low}..{high} "
                                 f"({command.name}, section {command.section})")
            setter = self.controller.motion.set_lp if name == "LP" else \
                self.controller.motion.set_ep
            setter(1 << axis, value, self.controller.clock)
            report = self.controller.motion.axis_report(axis, self.controller.clock)
            return Item(name, str(report.lp if name == "LP" else report.ep))
        raise ValueError(f"{' '.join(path)} {name} is read only")

    # ------------------------------------------------------------------ running
    def resume(self, mode: str, interrupted: Callable[[], bool]) -> Stopped:
        controller = self.controller
        if self.ended or not controller.stack:
            return self._end()
        frame = controller.stack[-1]
        fresh, self._fresh = self._fresh, False
        if mode == "entry":
            return Stopped("entry", controller.clock)
        # the line it stands at runs first, unless nothing ran yet (its breakpoints count)
        self._skip = None if fresh else (frame, frame.pc)
        self._mode, self._depth = mode, len(controller.stack)
        self._interrupted, self._stop = interrupted, None
        self._watched = {name: self.lookup(name) or 0 for name in self.data_points}
        # a plain function: the interrupt prediction deep-copies the motion model, which
        # reaches the controller; a function is copied as itself, a bound method is not
        controller.before_line = lambda frame: self._before(frame)
        try:
            while True:
                controller.advance(self.limit, until_idle=True)
                if self._stop is not None or controller.error is not None \
                        or not controller.stack or controller.clock >= self.limit:
                    break
        finally:
            controller.before_line = None
        if self._stop is not None:
            return self._stop
        if controller.error is not None or controller.stack:
            outcome = controller.outcome(self.limit, 0)  # R1xx raised, R201/R202 at the limit
            self.report.result = outcome
            self.error = self.report.failure
            self.ended = True
            return Stopped("exception", controller.clock, self.error)
        return self._end()

    def _end(self) -> Stopped:
        """The program finished: its motion runs out, as `mpc run` lets it."""
        controller = self.controller
        if not self.ended:
            self.ended = self.finished_ok = True
            end = controller.motion.idle_at(15, controller.clock)
            if end is not None:
                controller.clock = max(controller.clock, end)
                controller.motion.settle(controller.clock)
        return Stopped("exited", controller.clock, self.error, finished=self.finished_ok)

    def _before(self, frame: Frame) -> bool:
        """The controller's `before_line`: True stops before `frame.pc` runs."""
        skip, self._skip = self._skip, None
        if skip is not None and skip[0] is frame and skip[1] == frame.pc:
            return False  # the line it stopped at last: it runs now
        if self._interrupted():
            self._stop = Stopped("pause", self.controller.clock)
            return True
        table = frame.table
        line = self.lines[(table.kind, table.slot)][frame.pc]
        if not line.starts:
            return False
        for reason, points in (
                ("data breakpoint", self._changed()),
                ("function breakpoint", self.entry_points.get((table.kind, table.slot), ())
                 if frame.pc == 0 else ()),
                ("breakpoint", self.at_points.get((table.kind, table.slot, frame.pc), ()))):
            hit = tuple(point.id for point in points if point.reached())
            if hit:
                self._stop = Stopped(reason, self.controller.clock, breakpoints=hit)
                return True
        depth = len(self.controller.stack)
        mode = self._mode
        if mode == "in" or (mode == "next" and depth <= self._depth) \
                or (mode == "out" and depth < self._depth):
            self._stop = Stopped("step", self.controller.clock)
            return True
        return False

    # -------------------------------------------------------------- inspection
    def stack(self) -> Sequence[StackEntry]:
        if self.error is not None:  # the stack is gone: the finding's place and callers
            places = (self.error.where, *self.error.called_from)
            return [StackEntry(self._name(place.program, _kind(place.program)), place.file,
                               place.line, place.column, _kind(place.program))
                    for place in places]
        stack = self.controller.stack
        entries: list[StackEntry] = []
        for depth in range(len(stack) - 1, -1, -1):
            frame = stack[depth]
            above = stack[depth + 1] if depth + 1 < len(stack) else None
            # the top frame is before its next line; a caller is at its MP_CALL line; a
            # program an ISR interrupted, before its next line (or in its wait)
            pc = frame.pc if above is None or (above.table.kind == "isr" and frame.wait is
                                               None) else frame.pc - 1
            lines = self.lines[(frame.table.kind, frame.table.slot)]
            line = lines[max(0, min(pc, len(lines) - 1))]
            place = line.place
            entries.append(StackEntry(self._name(place.program, frame.table.kind), place.file,
                                      place.line, line.column, frame.table.kind))
        return entries

    def _changed(self) -> list[Breakpoint]:
        """The data breakpoints of the variables that changed since last seen."""
        changed: list[Breakpoint] = []
        for name, points in self.data_points.items():
            value = self.lookup(name) or 0
            if value != self._watched.get(name):
                self._watched[name] = value
                changed += points
        return changed

    @staticmethod
    def _name(program: str, kind: str) -> str:
        return f"{program} (interrupt)" if kind == "isr" else program

    def scopes(self) -> Sequence[tuple[str, Sequence[Item]]]:
        return [("Variables", self._variables()), ("Axes", self._axes()),
                ("Inputs", self._inputs())]

    def _variables(self) -> list[Item]:
        """Declared names (VAR, ALIAS) first, by device number, then every VARn and bVARn
        the programs use that has no name."""
        controller = self.controller
        named, numbers = self.report.named_vars()
        items = [Item(name, str(value), number=numbers[name])
                 for name, value in named.items() if name in numbers]
        shown = {int(number.removeprefix("VAR")) for number in numbers.values()}
        used: set[int] = set()
        used_bytes: set[int] = set()
        for table in controller.tables.values():
            for stored in table.lines:
                for operand in stored.operands:
                    if isinstance(operand, VarRef):
                        used.add(operand.index)
                    elif isinstance(operand, BVarRef):
                        used_bytes.add(operand.index)
        items += [Item(f"VAR{i}", str(controller.vars[i])) for i in sorted(used - shown)
                  if i < len(controller.vars)]
        items += [Item(f"bVAR{i}", str(controller.bvars[i])) for i in sorted(used_bytes)
                  if i < len(controller.bvars)]
        return items

    def _axes(self) -> list[Item]:
        controller = self.controller
        now = controller.clock
        items = []
        for i, name in enumerate(AXIS_NAMES):
            report = controller.motion.axis_report(i, now)
            cv = controller.motion.cv(1 << i, now)
            state = "driving" if report.driving else "stopped"
            if report.error_code:
                state += f", error code {report.error_code}"
            cv_text = f"{cv:g}"
            parts = (Item("LP", str(report.lp)), Item("EP", str(report.ep)),
                     Item("CV", cv_text), Item("state", state),
                     Item("servo", "on" if report.servo_on else "off"),
                     Item("home search state", str(report.home_state)))
            items.append(Item(name, f"LP {report.lp}, EP {report.ep}, CV {cv_text}, {state}",
                              parts))
        return items

    def _inputs(self) -> list[Item]:
        controller = self.controller
        items = []
        for i, name in enumerate(AXIS_NAMES):
            status = controller.motion.axis_report(i, controller.clock).di_status
            bits = tuple(Item(signal, "1" if bool(status >> bit & 1) == high else "0")
                         for signal, bit, high in _DI_BITS)
            active = [item.name for item in bits if item.value == "1"
                      and not item.name.endswith("level")]
            items.append(Item(f"{name} DI", ", ".join(active) or "none active", bits))
        for group in range(8, 16):
            items.append(Item(f"FRnet DI{group}", f"{controller.frnet[group]:016b}"))
        for group in range(8):
            items.append(Item(f"FRnet DO{group}", f"{controller.frnet[group]:016b}"))
        return items


def _kind(program: str) -> str:
    """"isr" for `ISR2 ...`, else "mp"."""
    return "isr" if program.upper().startswith("ISR") else "mp"
