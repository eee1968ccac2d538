"""Running a CSIM build on the virtual CSIM (`mpc run`/`mpc plot` for `--target csim`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.csim import profile as profile_module
from mplang.csim.build import POSITION_UNIT, CsimProgram, FamilyBuild
from mplang.csim.machine import Machine
from mplang.csim.machine_state import RunError
from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.family.run_error import RunError as RunFinding
from mplang.family.run_error import SourcePlace
from mplang.family.trace import SampledRun
from mplang.family.watch import Stopped, Watch

DEFAULT_SAMPLE_PERIOD = 0.001


__all__ = ["DEFAULT_SAMPLE_PERIOD", "FamilyRun", "NoSuchProgram", "RunSetupError", "run_build"]


@dataclass
class FamilyRun(SampledRun):
    """The outcome of one run: what `mpc run --json` prints, and the sampled path.

    The modules T0..T3 are reported as the axes X, Y, Z, U (the .mp axes compile to them);
    T4..T7 appear as "T4".."T7" when the program used them."""

    POSITION_UNIT = POSITION_UNIT

    called: str
    machine: Machine = field(repr=False)
    finished: bool = False
    error: str | None = None
    samples: list[tuple[float, dict[str, float]]] = field(default_factory=list)
    sample_period: float | None = None  # the grid of `samples` (None: not on a grid)
    program: CsimProgram | None = None  # the program that ran (its lines' source origins)

    @property
    def failure(self) -> RunFinding | None:
        """The error at the source line of the CSIM line it stopped at (a compiled .mp
        program keeps each line's .mp origin), with its code."""
        if self.error is None:
            return None
        machine, program = self.machine, self.program
        address = machine.error_address
        where = source_place(program, address)
        return RunFinding(machine.error_code, self.error, where,
                        program.name if program is not None else None, address,
                        round(machine.clock * 1000, 3), line_unit="line")

    @property
    def time_s(self) -> float:
        return self.machine.clock

    @property
    def printed(self) -> list[str]:
        """What the program sent to the host with OUT."""
        return self.machine.printed

    def named_vars(self) -> tuple[dict[str, float], dict[str, str]]:
        """The variables by name: every declared one of an .mp build (VAR name, ALIAS) that
        the program uses, zero or not, by its name; then the other non-zero ones by the
        CSIM's name; and each declared name's CSIM variable (`rows_done`: `R1`)."""
        found = self.machine.variables()
        names = dict(self.program.names) if self.program is not None else {}
        named: dict[str, float] = {}
        for name, variable in names.items():
            named[name] = found.get(variable, 0)
        shown = set(names.values())
        named.update({key: value for key, value in found.items() if key not in shown})
        return named, names

    def to_json(self) -> dict[str, object]:
        named, names = self.named_vars()
        return {"called": self.called, "vars": named, "names": names,
                "axes": self.machine.axes(), "time_ms": round(self.machine.clock * 1000, 3),
                "error": self.failure.to_json() if self.failure is not None else None}


def source_place(program: CsimProgram | None, address: int | None) -> SourcePlace:
    """The source of a CSIM line (a compiled .mp program keeps each line's .mp origin), or
    the program's file."""
    where = SourcePlace(program.source if program is not None else None,
                        program=program.name if program is not None else "")
    if program is not None and address is not None and 0 <= address < len(program.origins):
        span = program.origins[address]
        where = SourcePlace(span.file, span.line, span.col, program.name)
    return where


def pick_entry(build: FamilyBuild, call: str | None) -> tuple[CsimProgram, int, str]:
    """The program and address to run: `call` is None (the first program from address 0),
    a program name, an entry of a compiled build (MP name or MPn), a label ($NAME or NAME) of
    the first program that has it, or `program:label`."""
    if not build.programs:
        raise NoSuchProgram("the build has no program to run")
    if call is None:
        program = build.programs[0]
        return program, 0, program.name
    wanted_program, _, wanted_label = call.rpartition(":")
    candidates = build.programs
    if wanted_program:
        candidates = [p for p in build.programs if p.name.upper() == wanted_program.upper()]
        if not candidates:
            raise NoSuchProgram(f"no program named {wanted_program!r} in this build"
                                f"{_callable(build.programs)}")
    key = wanted_label.upper()
    for program in candidates:
        if not wanted_program and program.name.upper() == key:
            return program, 0, program.name
        entry = next((label for name, label in program.entries.items()
                      if name.upper() == key), None)
        label = (entry or wanted_label).lstrip("$").upper()
        labels = program.script.labels
        if label in labels:
            return program, labels[label], f"{program.name}:${label}"
    raise NoSuchProgram(f"{call!r} names no program, entry or label of this build"
                        f"{_callable(build.programs)}")


def _callable(programs: list[CsimProgram]) -> str:
    """"; callable: prog, prog:entry, prog:$LABEL" for a message."""
    names: list[str] = []
    for program in programs:
        names.append(program.name)
        names += [f"{program.name}:{entry}" for entry in program.entries]
        names += [f"{program.name}:${label}" for label in program.script.labels]
    return f"; callable: {', '.join(names)}" if names else ""


def run_build(build: FamilyBuild, call: str | None, max_time: float, *,
              inputs: dict[int, bool] | None = None,
              sample_period: float | None = DEFAULT_SAMPLE_PERIOD,
              machine: object | None = None, watch: Watch | None = None) -> FamilyRun:
    """Load a program into a fresh virtual CSIM, run it from `call` until it ends, fails or
    `max_time` seconds of simulated time pass (infinite: no limit). `inputs` sets inputs
    1..8 for the whole run. Samples: every `sample_period` of simulated time while anything
    moves, plus every segment end. `watch` sees the run between lines and may stop it."""
    if machine is not None:  # the face's `load_machine` is None: nothing to place
        raise RunSetupError("the virtual CSIM takes no machine file")
    if not build.ok:
        raise RunSetupError("the build has errors; fix them before running it")
    program, address, called = pick_entry(build, call)
    profile = profile_module.load()
    machine = Machine(profile, program.script, sample_period)
    for number, state in (inputs or {}).items():
        if not 1 <= number <= profile.inputs:
            raise RunSetupError(f"input {number} does not exist (1..{profile.inputs})")
        machine.inputs[number - 1] = state
    try:
        machine.start(address)
    except RunError as exc:
        raise RunSetupError(str(exc)) from None
    if watch is not None:
        machine.watch = lambda now: watch(now, lambda: source_place(
            program, max(machine.pc - 1, 0) if machine.wait is None else machine.wait_address))
    try:
        machine.run(max_time)
    except Stopped:  # the watch stopped it (Ctrl-C): the state as it stands
        return FamilyRun(called, machine, False, None,
                         [(s.time, s.positions) for s in machine.samples], sample_period,
                         program)
    samples = [(s.time, s.positions) for s in machine.samples]
    return FamilyRun(called, machine, machine.error is None and not machine.running,
                     machine.error, samples, sample_period, program)
