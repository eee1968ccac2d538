"""`mpc run` for FBs-PLC tables: one EN=1 of one table on a fresh virtual PLC.

`run_build` answers in the shape of the M8194H's `mpc run --json` (`mplang.m8194h.run`): the keys
called, vars, axes (X/Y/Z/U = Ps0-Ps3, lp and ep), time_ms and error. `vars` lists every
non-zero 16-bit register of the virtual PLC (the work registers, DR4088..., the SIM values).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.family.run_error import RunError, SourcePlace
from mplang.family.trace import SampledRun
from mplang.family.watch import Stopped, Watch
from mplang.fatek.build import POSITION_UNIT, FamilyBuild
from mplang.fatek.machine import Machine, PlcError, Stuck, axis_params
from mplang.fatek.model import Contact, ParamTable, PositioningTable, Register
from mplang.fatek.motion import Leg, round_half_up

SAMPLE_PERIOD = 0.001
"""By default samples fall at least every millisecond of simulated time while an axis moves."""


class NoSuchTable(NoSuchProgram):
    """The call names no runnable table of the build (or a step it does not have)."""


@dataclass
class FamilyRun(SampledRun):
    """What one run did: where the axes ended, the registers, and the motion over time."""

    POSITION_UNIT = POSITION_UNIT

    called: str
    finished: bool
    error: str | None
    time_s: float
    positions: tuple[int, ...]
    axis_names: tuple[str, ...]
    registers: dict[Register, int] = field(default_factory=dict)
    relays: frozenset[Contact] = frozenset()
    legs: list[Leg] = field(default_factory=list)
    steps: int = 0
    log: list[str] = field(default_factory=list)
    wr_trace: list[tuple[float, int]] = field(default_factory=list)
    """(time in s, WR+1) at the start and at every change of WR+1's status bits (FB 757-763):
    B9 waiting for the transition, B10 continuous run, B12 pulsing, B13 error, B14 step done."""
    sample_period: float | None = SAMPLE_PERIOD  # None: leg starts, ends and boundaries only
    failure: RunError | None = None  # the error at its step's source line, with its code

    def to_json(self) -> dict[str, object]:
        """The `mpc run --json` shape of the M8194H (mplang/m8194h/run.py)."""
        registers = {str(r): v for r, v in sorted(self.registers.items()) if v}
        axes = {name: {"lp": pos, "ep": pos}
                for name, pos in zip(self.axis_names, self.positions, strict=True)}
        return {"called": self.called, "vars": registers, "names": {}, "axes": axes,
                "time_ms": round(self.time_s * 1000, 3),
                "error": self.failure.to_json() if self.failure is not None else None}

    @property
    def samples(self) -> list[tuple[float, dict[str, int]]]:
        """(time in s, {axis: position}) at the start and end of every motion leg, at every
        step boundary inside a DRVC chain, and every `sample_period` (1 ms by default) of
        simulated time while a leg moves."""
        out: list[tuple[float, dict[str, int]]] = []
        start = self.legs[0].start if self.legs else tuple(float(p) for p in self.positions)
        self._add(out, 0.0, start)
        for leg in self.legs:
            end = min(leg.t_end, self.time_s)
            if end < leg.t0:
                continue
            times = {leg.t0, end, *(b for b in leg.boundaries if leg.t0 <= b <= end)}
            period = self.sample_period
            if period is not None:
                first = math.ceil(leg.t0 / period - 1e-9)
                last = math.floor(end / period + 1e-9)
                times.update(k * period for k in range(first, last + 1)
                             if leg.t0 <= k * period <= end)
            for when in sorted(times):
                self._add(out, when, leg.positions(when))
        self._add(out, self.time_s, tuple(float(p) for p in self.positions))
        return out

    def _add(self, out: list[tuple[float, dict[str, int]]], when: float,
             positions: tuple[float, ...]) -> None:
        point = {name: round_half_up(p)
                 for name, p in zip(self.axis_names, positions, strict=True)}
        if out and when <= out[-1][0]:
            out[-1] = (out[-1][0], point)
            return
        out.append((when, point))


_CALL = re.compile(r"(?P<name>.+?)(?::(?P<step>\d+))?")


def pick_table(build: FamilyBuild, call: str | None) -> tuple[PositioningTable, int]:
    """`NAME` or `NAME:STEP` (start at that step, as WR+0 = STEP-1 does, FB 753-755); a table
    compiled from MP21 also answers to `MP21`. By default the first positioning table of the
    build, from step 1."""
    tables = build.positioning_tables()
    if call is None:
        if not tables:
            raise NoSuchTable("the build has no FUN140 or FUN147 table to run")
        return tables[0], 1
    match = _CALL.fullmatch(call.strip())
    if match is None:
        raise NoSuchTable(f"cannot read {call!r}: use NAME or NAME:STEP")
    name = match.group("name")
    found = next((t for t in build.programs if t.name.upper() == name.upper()), None) or \
        next((t for t in tables if t.origin and t.origin.upper() == name.upper()), None)
    if found is None:
        names = ", ".join(t.name for t in tables) or "none"
        raise NoSuchTable(f"no table named {name!r} in this build (tables: {names})")
    if isinstance(found, ParamTable):
        raise NoSuchTable(f"{name!r} is a FUN141 parameter table; it does not run")
    step = int(match.group("step") or 1)
    if not 1 <= step <= len(found.steps):
        raise NoSuchTable(f"{name!r} has steps 1-{len(found.steps)}, not {step}")
    return found, step


def run_build(build: FamilyBuild, call: str | None = None, max_time: float = 3600.0, *,
              sample_period: float | None = SAMPLE_PERIOD,
              machine: object | None = None, watch: Watch | None = None) -> FamilyRun:
    """Run one table of the build (see `pick_table`) on a fresh virtual PLC until MEND, an
    error, a wait that never ends, or `max_time` seconds of simulated time (infinite: no
    limit). `sample_period` is the grid of `FamilyRun.samples` (None: motion starts and
    ends only); the samples are computed from the recorded legs when asked for, so the run
    itself is the same. `watch` sees the run before every step and may stop it there."""
    if sample_period is not None and not sample_period > 0:
        raise ValueError(f"the sampling period must be positive, got {sample_period}")
    if machine is not None:  # the face's `load_machine` is None: SIM lines describe it
        raise RunSetupError("a FATEK table takes no machine file: SIM lines describe its inputs")
    if not build.ok:
        raise RunSetupError("the build has errors; the virtual PLC runs only checked tables")
    table, entry = pick_table(build, call)
    profile = build.profile
    params = axis_params(profile, [t for t in build.programs if isinstance(t, ParamTable)])
    machine = Machine(profile, table, params, build.sim, max_time)
    if watch is not None:
        machine.watch = lambda now: watch(now, lambda: _place(table, machine))
    error: str | None = None
    code = "R401"
    finished = False
    try:
        machine.run(entry)
        finished = True
    except PlcError as exc:
        machine.set_word(machine.error_register(), exc.code)
        machine.set_flags(on=machine.wr_bit("wr_error_bit"))
        error = f"PLC error {exc.code} ({profile.error_text(exc.code)}): {exc.detail}"
        machine.note(error)
    except Stuck as exc:
        error, code = str(exc), exc.code
        machine.note(error)
    except Stopped as exc:  # the watch stopped it (Ctrl-C): the state as it stands
        machine.note(str(exc))
    machine.record_positions()
    called = table.name if entry == 1 else f"{table.name}:{entry}"
    return FamilyRun(
        called=called, finished=finished, error=error, time_s=machine.time,
        positions=tuple(round_half_up(p) for p in machine.rest),
        axis_names=profile.axis_names, registers=dict(machine.registers),
        relays=frozenset(machine.relays), legs=machine.legs, steps=machine.steps_run,
        log=machine.log, sample_period=sample_period, wr_trace=machine.wr_trace,
        failure=None if error is None else _located(table, machine, code, error))


def _located(table: PositioningTable, machine: Machine, code: str, error: str) -> RunError:
    """The run's error at the source line of the step that ran (a table compiled from an
    .mp file keeps the .mp line of each step), or at the table when no step ran."""
    return RunError(code, error, _place(table, machine), table.name, machine.at_step,
                    round(machine.time * 1000, 3), line_unit="step")


def _place(table: PositioningTable, machine: Machine) -> SourcePlace:
    """The source line of the step that runs (or ran last), or the table's."""
    step = machine.at_step
    span = table.steps[step - 1].span if step is not None and \
        1 <= step <= len(table.steps) else table.span
    program = table.name + (f" ({table.origin})" if table.origin else "")
    return SourcePlace(span.file, span.line, span.col, program) if span.line > 0 \
        else SourcePlace(table.source or None, program=program)
