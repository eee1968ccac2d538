"""`mpc run`: build, load every program into a fresh virtual controller, call one, report."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.family.run_error import RunError, SourcePlace
from mplang.family.trace import Trace
from mplang.family.watch import Watch, never_stop
from mplang.m8194h.image import BuildResult, ProgramImage
from mplang.m8194h.machine import MachineSetup, apply_machine
from mplang.m8194h.sim.controller import RunResult, VirtualController
from mplang.m8194h.sim.failure import Failure, Place
from mplang.m8194h.sim.preload import ServiceError, preload
from mplang.m8194h.sim.unmodelled import Notice
from mplang.m8194h.trace import run_traced
from mplang.m8194h.watched import run_watched, running_place

__all__ = ["NoSuchProgram", "RunReport", "RunSetupError", "pick_program", "run_build",
           "run_family"]


@dataclass
class RunReport:
    controller: VirtualController
    result: RunResult
    called: str
    trace: Trace | None = None
    title: str = ""  # the called program in words: `MP131 home (samples/home.mp)`
    build: BuildResult | None = None  # for the source lines of `warnings`
    machine: Path | None = None  # the machine file the run used (`--json`: "machine")

    @property
    def warnings(self) -> list[str]:
        """Every command the run met that the virtual controller does not simulate, at
        its source line (`file:line:col: warning[R301]: ...`), once per program line; then
        every axis stop (limit, alarm, emergency, failed home search, R311-R315) at the line
        the program was at, once per cause and axis."""
        return [self._notice_text(finding) if finding.code == "R301" else finding.render()
                for finding in self.findings]

    @staticmethod
    def _notice_text(finding: RunError) -> str:
        return f"{finding.where.prefix()}warning[R301]: {finding.message}"

    @property
    def findings(self) -> list[RunError]:
        """`warnings` as data (`--json`: "warnings", each as the "error" object)."""
        stops = [self.located(stop) for stop in self.controller.stops.values()]
        return [*(self._warning(notice) for notice in self.controller.notices), *stops]

    def _warning(self, notice: Notice) -> RunError:
        where = self.source_of(Place(notice.kind, notice.slot, notice.line))
        return RunError("R301", f"{notice.command} is not modelled by the virtual controller: "
                        f"it ran with no effect ({notice.where()})", where,
                        None if notice.kind == "rtc" else f"{notice.kind.upper()}{notice.slot}",
                        None if notice.kind == "rtc" else notice.line)

    def source_of(self, place: Place) -> SourcePlace:
        """The source line a slot line was compiled from (see `source_place`)."""
        return source_place(self.build, place)

    @property
    def failure(self) -> RunError | None:
        """Why the run failed, at its source line, with the call chain; None if it finished."""
        found = self.result.failure
        if found is None:
            if self.result.error is None:
                return None
            return RunError("R309", self.result.error, time_ms=round(self.time_s * 1000, 3))
        return self.located(found)

    def located(self, found: Failure) -> RunError:
        """A finding of the controller at its source line, with its callers' lines."""
        where = self.source_of(found.place) if found.place is not None else SourcePlace(None)
        return RunError(
            found.code, found.message, where,
            f"{found.place.kind.upper()}{found.place.slot}" if found.place else None,
            found.place.slot_line if found.place else None, round(found.time_s * 1000, 3),
            tuple(self.source_of(caller).replace(via="interrupt" if callee is not None
                                                 and callee.kind == "isr" else "call")
                  for caller, callee in zip(found.callers, (found.place, *found.callers),
                                            strict=False)))

    def named_vars(self) -> tuple[dict[str, int], dict[str, str]]:
        """The variables by name: every declared one (VAR name, ALIAS), zero or not, then
        every other non-zero VARn; and each declared name's device number (`VAR400`)."""
        values = self.controller.vars
        declared = sorted([*self.build.variables, *self.build.aliases] if self.build else [],
                          key=lambda v: v.index)
        named: dict[str, int] = {}
        numbers: dict[str, str] = {}
        for variable in declared:
            if variable.name not in named and 0 <= variable.index < len(values):
                named[variable.name] = values[variable.index]
                numbers[variable.name] = f"VAR{variable.index}"
        shown = {variable.index for variable in declared}
        named.update({f"VAR{i}": v for i, v in enumerate(values) if v and i not in shown})
        return named, numbers

    @property
    def finished(self) -> bool:
        return self.result.finished

    @property
    def error(self) -> str | None:
        return self.result.error

    @property
    def time_s(self) -> float:
        return self.result.time_s

    def headline_detail(self, controller: str) -> str:
        """The macro lines the run executed (the M8194H's headline)."""
        return f", {self.result.steps} lines"

    def plot_title(self, controller: str, sources: str) -> str:
        return self.title or self.called

    def to_json(self) -> dict[str, object]:
        """The `mpc run --json` summary: called (the program, "MP21"), vars (by declared
        name), names (each declared name's VARn), axes, time_ms, error (an object, see
        docs/cli.md); the other families' runs give the same keys."""
        snapshot = self.controller.snapshot()
        named, numbers = self.named_vars()
        failure = self.failure
        summary: dict[str, object] = {
            "called": self.called, "vars": named, "names": numbers, "axes": snapshot["axes"],
            "time_ms": round(self.result.time_s * 1000, 3),
            "error": failure.to_json() if failure is not None else None}
        if self.machine is not None:
            summary["machine"] = str(self.machine)
        findings = self.findings
        if findings:  # only when there are any, so a clean run's summary keeps its keys
            summary["warnings"] = [finding.to_json() for finding in findings]
        return summary


def _image(build: BuildResult | None, kind: str, slot: int) -> ProgramImage | None:
    for image in build.programs if build is not None else ():
        if (image.program.kind, image.placement.slot) == (kind, slot):
            return image
    return None


def source_place(build: BuildResult | None, place: Place | None) -> SourcePlace:
    """The source line a slot line was compiled from (`std:` and INCLUDEd files too):
    the image keeps each frame's span, and a line spans `line_cost` slot lines."""
    if place is None:
        return SourcePlace(None)
    image = _image(build, place.kind, place.slot)
    program = f"{place.kind.upper()}{place.slot}"
    if image is None:
        return SourcePlace(None, program=program)
    if image.program.name:
        program += f" {image.program.name}"
    for frames in image.lines:
        first = frames.first_slot_line
        if first <= place.slot_line < first + max(1, frames.line.command.line_cost):
            span = frames.line.span
            return SourcePlace(span.file, span.line, span.col, program)
    span = image.close_span  # the closing line: the return to the caller
    return SourcePlace(span.file, span.line, span.col, program)


def declared_variables(build: BuildResult) -> list[tuple[str, int]]:
    """Every declared variable (VAR name, ALIAS) once, by device number, as a trace labels
    it: (`rows_done (VAR400)`, 400)."""
    seen: set[str] = set()
    found: list[tuple[str, int]] = []
    for variable in sorted([*build.variables, *build.aliases], key=lambda v: v.index):
        if variable.name not in seen:
            seen.add(variable.name)
            found.append((f"{variable.name} (VAR{variable.index})", variable.index))
    return found


def pick_program(build: BuildResult, call: str | None, first_file: str | None) -> int:
    """The MP slot to call: `MPn`, `n` or a program name; by default the first MP of the
    first file."""
    mps = [p for p in build.programs if p.program.kind == "mp"]
    if call is None:
        ordered = sorted(mps, key=lambda p: (p.program.source != first_file,
                                             p.program.source, p.program.span.line))
        if not ordered:
            raise NoSuchProgram("the build has no MP program to call")
        return ordered[0].placement.slot
    match = re.fullmatch(r"(?:MP)?(\d+)", call, re.IGNORECASE)
    if match:
        slot = int(match.group(1))
        if not any(p.placement.slot == slot for p in mps):
            raise NoSuchProgram(f"MP{slot} is not part of this build{_callable(mps)}")
        return slot
    named = [p for p in mps if (p.program.name or "").upper() == call.upper()]
    if not named:
        raise NoSuchProgram(f"no MP named {call!r} in this build{_callable(mps)}")
    return named[0].placement.slot


def _callable(mps: list[ProgramImage]) -> str:
    """"; callable: MP100 tour, MP131 home" for a message (every MP of the build)."""
    names = [f"MP{p.placement.slot}" + (f" {p.program.name}" if p.program.name else "")
             for p in sorted(mps, key=lambda p: p.placement.slot)]
    return f"; callable: {', '.join(names)}" if names else ""


def run_build(build: BuildResult, call: str | None = None, first_file: str | None = None,
              max_time: float = 3600.0, trace_period: float | None = None,
              machine: MachineSetup | None = None, watch: Watch | None = None) -> RunReport:
    """Load the build into a fresh virtual controller and run one MP to its end, on
    `machine` if given (`mplang.m8194h.machine`). With `trace_period` (seconds) every axis
    is also sampled over the run (`RunReport.trace`); the run itself comes out the same
    either way. An infinite `max_time` is no limit; `watch` sees the run between slices and
    may stop it (`mplang.family.watch`)."""
    controller = VirtualController(word_order=build.word_order)
    try:  # the programs, then the INIT table (loaded) and the TRIGGERS table, as flashed
        preload(controller, build)
    except ServiceError as exc:
        raise RunSetupError(str(exc)) from None
    if machine is not None:
        apply_machine(controller, machine)
    slot = pick_program(build, call, first_file)
    controller.call(slot)

    places: dict[Place | None, SourcePlace] = {}  # a trace asks at every sample

    def where() -> SourcePlace:
        place = running_place(controller)
        found = places.get(place)
        if found is None:
            found = places[place] = source_place(build, place)
        return found

    if trace_period is None:
        if watch is None and math.isfinite(max_time):
            result = controller.run(max_time=max_time)
        else:
            result = run_watched(controller, max_time, watch or never_stop, where)
        return RunReport(controller, result, f"MP{slot}", build=build)
    result, trace = run_traced(controller, trace_period, max_time=max_time, watch=watch,
                               where=where, variables=declared_variables(build))
    report = RunReport(controller, result, f"MP{slot}", trace, build=build)
    failure = report.failure
    if failure is not None and failure.where.line is not None and trace.places:
        trace.places[-1] = f"{failure.where.file}:{failure.where.line}"  # where it failed
    return report


def run_family(build: BuildResult, call: str | None, max_time: float, *,
               sample_period: float | None = None, machine: object | None = None,
               watch: Watch | None = None) -> RunReport:
    """`run_build` as the family face calls it: the default program is the first MP of the
    first file given to the compiler; `machine` is what the face's `load_machine` read."""
    if machine is not None and not isinstance(machine, MachineSetup):
        raise RunSetupError(f"not an M8194H machine: {machine!r}")
    report = run_build(build, call, build.first_source, max_time=max_time,
                       trace_period=sample_period, machine=machine, watch=watch)
    report.machine = machine.path if machine is not None else None
    report.title = program_title(build, report.called)
    return report


def program_title(build: BuildResult, called: str) -> str:
    """`MP131 home_then_square (samples/home_then_square.mp)` for the called slot."""
    slot = int(called.removeprefix("MP"))
    for image in build.programs:
        if image.program.kind == "mp" and image.placement.slot == slot:
            name = f" {image.program.name}" if image.program.name else ""
            return f"{called}{name} ({image.program.source})"
    return called
