"""`mpc run`: build, load every program into a fresh virtual controller, call one, report."""

from __future__ import annotations

import re
from dataclasses import dataclass

from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.family.trace import Trace
from mplang.m8194h.image import BuildResult, ProgramImage
from mplang.m8194h.sim.controller import RunResult, VirtualController
from mplang.m8194h.sim.preload import ServiceError, preload
from mplang.m8194h.sim.unmodelled import Notice
from mplang.m8194h.trace import run_traced

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

    @property
    def warnings(self) -> list[str]:
        """Every command the run met that the virtual controller does not simulate, at
        its source line (`file:line: warning: ...`), once per program line."""
        return [self._warning(notice) for notice in self.controller.notices]

    def _warning(self, notice: Notice) -> str:
        where = ""
        for image in self.build.programs if self.build is not None else ():
            if (image.program.kind, image.placement.slot) == (notice.kind, notice.slot):
                for line in image.lines:
                    if line.first_slot_line == notice.line:
                        where = f"{line.line.span.file}:{line.line.span.line}: "
        return (f"{where}warning: {notice.command} is not modelled by the virtual controller:"
                f" it ran with no effect ({notice.where()})")

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
        """The `mpc run --json` summary: called (the program, "MP21"), vars, axes, time_ms,
        error; the other families' runs give the same keys."""
        summary: dict[str, object] = {"called": self.called, **self.controller.snapshot()}
        summary["time_ms"] = round(self.result.time_s * 1000, 3)
        summary["error"] = self.result.error
        return summary


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
              max_time: float = 3600.0, trace_period: float | None = None) -> RunReport:
    """Load the build into a fresh virtual controller and run one MP to its end. With
    `trace_period` (seconds) every axis is also sampled over the run (`RunReport.trace`);
    the run itself comes out the same either way."""
    controller = VirtualController(word_order=build.word_order)
    try:  # the programs, then the INIT table (loaded) and the TRIGGERS table, as flashed
        preload(controller, build)
    except ServiceError as exc:
        raise RunSetupError(str(exc)) from None
    slot = pick_program(build, call, first_file)
    controller.call(slot)
    if trace_period is None:
        return RunReport(controller, controller.run(max_time=max_time), f"MP{slot}",
                         build=build)
    result, trace = run_traced(controller, trace_period, max_time=max_time)
    return RunReport(controller, result, f"MP{slot}", trace, build=build)


def run_family(build: BuildResult, call: str | None, max_time: float, *,
               sample_period: float | None = None) -> RunReport:
    """`run_build` as the family face calls it: the default program is the first MP of the
    first file given to the compiler."""
    report = run_build(build, call, build.first_source, max_time=max_time,
                       trace_period=sample_period)
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
