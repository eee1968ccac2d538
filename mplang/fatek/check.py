"""Every limit and rule FB gives for positioning tables, checked before the PLC sees them.

The checks mirror the error codes the PLC raises at run time (30-60, FB 772-807) and the
rules of the instruction descriptions (DRVC chains, operand ranges, table sizes, register
areas), plus FUN141's parameter codes 1-15. They run on any model: a parsed listing or a
compiled `.mp` program.
"""

from __future__ import annotations

from collections.abc import Iterable

from mplang.fatek.model import (
    NEXT,
    Contact,
    Drive,
    Home,
    Line,
    ParamTable,
    PositioningTable,
    Register,
    SimSetup,
    Step,
    Table,
    Value,
)
from mplang.fatek.profile import Area, FunLimits, Profile
from mplang.fatek.units import MECHANICAL_UNITS, AxisParams
from mplang.lang.diagnostics import DiagnosticSink, Span


def settle_implicit(tables: Iterable[Table], fun: int | None) -> None:
    """A listing without a TABLE line runs on the target's instruction, or, without a target,
    on FUN147 if it interpolates (LIN/LINE) and FUN140 otherwise."""
    for table in tables:
        if isinstance(table, PositioningTable) and table.fun == 0:
            lines = any(isinstance(s.motion, Line) for s in table.steps)
            table.fun = fun if fun is not None else 147 if lines else 140


def table_words(table: Table, profile: Profile) -> int:
    """Registers a table occupies: N x 9 + 2 (FUN140, FB 1156-1157), N x 15 + 2 (FUN147,
    FB 2399-2400) or 24 (FUN141, FB 1412-1414)."""
    if isinstance(table, ParamTable):
        return profile.fun141_words
    limits = profile.limits(table.fun)
    return limits.header_words + limits.words_per_step * len(table.steps)


class Checker:
    """Checks a whole build: tables see each other (register overlaps, FUN141 of an axis)."""

    def __init__(self, profile: Profile, sink: DiagnosticSink) -> None:
        self.profile = profile
        self.sink = sink
        self.params: dict[int, ParamTable] = {}

    def check(self, tables: list[Table], sim: SimSetup) -> None:
        names: dict[str, Span] = {}
        for table in tables:
            key = table.name.upper()
            if key in names:
                self.sink.add("E616", table.span, f"a table named {table.name!r} exists already",
                              related=((names[key], "first table of that name"),),
                              hint="give every table its own name")
            names.setdefault(key, table.span)
            if isinstance(table, ParamTable):
                self.param_table(table)
        for table in tables:
            if isinstance(table, PositioningTable):
                self.positioning_table(table)
        self.overlaps(tables)
        self.sim(sim)

    def axis_params(self, axis: int) -> AxisParams:
        return AxisParams.of(self.profile, self.params.get(axis))

    # ------------------------------------------------------------ registers
    def area_of(self, register: Register, words: int, areas: tuple[Area, ...]) -> Area | None:
        return next((a for a in areas if a.holds(register.kind, register.number, words)), None)

    def variable(self, value: Value | None, words: int, span: Span, what: str,
                 code: str = "30/32") -> None:
        if not isinstance(value, Register):
            return
        if self.area_of(value, words, self.profile.variable_areas) is None:
            areas = ", ".join(str(a) for a in self.profile.variable_areas)
            size = "the pair " + f"{value}/{value.offset(1)}" if words == 2 else str(value)
            self.sink.add("E606", span, f"{what} names {size}, outside the registers a "
                          f"variable operand may use (PLC error {code})",
                          hint=f"use a register in {areas}" + (
                              "; a 32-bit operand needs both words in one area" if words == 2
                              else ""))

    # ------------------------------------------------------------ tables
    def header(self, table: Table, words: int, work: int) -> None:
        kind = "Gp" if isinstance(table, PositioningTable) and table.fun == 147 else "Ps"
        unit = table.unit if isinstance(table, PositioningTable) else table.axis
        limit = self.profile.fun147.unit_max if kind == "Gp" else self.profile.fun140.unit_max
        if not 0 <= unit <= limit:
            self.sink.add("E616", table.span, f"{kind}{unit} does not exist: the PLC has "
                          f"{kind}0-{kind}{limit}", hint="FUN140/FUN141 take Ps0-Ps3 "
                          "(FB 525-529), FUN147 Gp0-Gp1 (FB 1846)")
        areas = ", ".join(str(a) for a in self.profile.table_areas)
        for label, start, size in (("SR", table.sr, words),
                                   ("WR", getattr(table, "wr", None), work)):
            if start is None or size == 0:
                continue
            if self.area_of(start, size, self.profile.table_areas) is None:
                last = start.offset(size - 1)
                self.sink.add("E616", table.span, f"{label} {start}-{last} ({size} registers) "
                              f"does not fit in one register area", hint=f"areas: {areas} "
                              "(FB 546-565)")

    def param_table(self, table: ParamTable) -> None:
        self.header(table, self.profile.fun141_words, 0)
        if table.axis in self.params:
            first = self.params[table.axis]
            self.sink.add("E616", table.span, f"a second FUN141 table for Ps{table.axis}",
                          related=((first.span, f"{first.name!r} sets Ps{table.axis}"),),
                          hint="one FUN141 per axis (FB 1457)")
        else:
            self.params[table.axis] = table
        mechanical = table.values.get(0, 1) == MECHANICAL_UNITS
        for number, value in table.values.items():
            span = table.spans.get(number, table.span)
            spec = self.profile.param(number)
            if spec is None:
                self.sink.add("E618", span, f"FUN141 has no parameter {number}",
                              hint="parameters 0-17 (FB 1461-1503)")
                continue
            low, high = spec.min, spec.max
            if mechanical and spec.mechanical_max is not None:
                low, high = spec.mechanical_min or low, spec.mechanical_max
            code = f" (PLC error {spec.error})" if spec.error else ""
            if not low <= value <= high:
                self.sink.add("E618", span, f"parameter {number} ({spec.name}) = {value} is "
                              f"outside {low}..{high}{code}", hint=f"{spec.doc} ({spec.lines})")
            elif spec.bytes_0_or_1 and (value & 0xFF > 1 or value >> 8 > 1):
                self.sink.add("E618", span, f"parameter {number} ({spec.name}) = {value:04X}H: "
                              f"each byte must be 0 or 1{code}", hint=spec.doc)
        params = AxisParams.of(self.profile, table)
        if mechanical and 4 in table.values and params.max_speed > self.profile.fun140.speed_max:
            self.sink.add("E618", table.spans[4], f"parameter 4 = {params[4]} is "
                          f"{params.max_speed:.0f} Ps/s with A = {params.pulses_per_rev} and "
                          f"B = {params.travel_per_rev}, above 921600 Ps/s (PLC error 5)",
                          hint="f_max = V_max x 1000 x A / (6 x B) <= 921600 (FB 1578)")

    def positioning_table(self, table: PositioningTable) -> None:
        limits = self.profile.limits(table.fun)
        self.header(table, table_words(table, self.profile), limits.work_registers)
        count = len(table.steps)
        if not 1 <= count <= limits.max_steps:
            where = table.steps[limits.max_steps].span if count > limits.max_steps else table.span
            self.sink.add("E603", where, f"{table.name!r} has {count} steps; a FUN{table.fun} "
                          f"table holds 1-{limits.max_steps} (PLC error 36)",
                          hint="split the program into several tables")
        for index, step in enumerate(table.steps):
            if step.number != index + 1:
                self.sink.add("E602", step.where("number"), f"step {step.number} stands where "
                              f"step {index + 1} belongs", hint="steps are numbered 001, 002, "
                              "... in order; the table stores them by position")
            self.step(table, limits, index, step)
        if table.fun == 140:
            self.drvc_chains(table)

    def step(self, table: PositioningTable, limits: FunLimits, index: int, step: Step) -> None:
        name = f"step {step.number}"
        if step.speed is None:
            self.sink.add("E615", step.span, f"{name} has no SPD", hint="every step starts with "
                          "its output speed (FB 571-575)")
        if step.motion is None:
            self.sink.add("E615", step.span, f"{name} has no motion", hint="DRV, DRVC or DRVZ "
                          "(FUN140); LIN or LINE (FUN147)")
        if step.goto is None and not step.mend:
            self.sink.add("E615", step.span, f"{name} has no GOTO or MEND",
                          hint="end a step with GOTO NEXT, GOTO n or MEND")
        self.speed(table, limits, step)
        motion = step.motion
        op = (motion.op if isinstance(motion, Drive | Line) else "DRVZ") if motion else ""
        if motion is not None and op not in limits.instructions:
            code = 60 if table.fun == 147 else 43
            self.sink.add("E614", step.where("motion"), f"{op} is not a FUN{table.fun} "
                          f"instruction (PLC error {code})", hint="FUN140: DRV, DRVC, DRVZ; "
                          "FUN147: LIN, LINE (FB 474-490)")
        elif isinstance(motion, Drive):
            self.drive(table, limits, step, motion)
        elif isinstance(motion, Line):
            self.line(table, limits, step, motion)
        elif isinstance(motion, Home):
            self.home(table, step, motion)
        self.condition(table, limits, step)
        self.transition(table, index, step)

    def speed(self, table: PositioningTable, limits: FunLimits, step: Step) -> None:
        where = step.where("speed.value")
        if isinstance(step.speed, Register):
            self.variable(step.speed, 2, where, "SPD", "30")
            return
        if step.speed is None:
            return
        if step.speed == 0:
            self.sink.add("E604", where, "SPD 0 never starts: the step waits until the speed "
                          "is not 0 (FB 885-887)", hint=f"use {limits.speed_min}.."
                          f"{limits.speed_max:,}, or a register the ladder sets")
        elif not limits.speed_min <= step.speed <= limits.speed_max:
            self.sink.add("E604", where, f"SPD {step.speed} is outside {limits.speed_min}.."
                          f"{limits.speed_max} (PLC error 31)",
                          hint="FB 883" if table.fun == 140 else "FB 2191")
        elif table.fun == 140:
            params = self.axis_params(table.unit)
            if params.unit_system != MECHANICAL_UNITS and step.speed > params.max_speed:
                self.sink.add("W604", where, f"SPD {step.speed} is above the maximum speed of "
                              f"Ps{table.unit} (FUN141 parameter 4 = {params[4]}); the output "
                              "is capped there", hint="raise parameter 4, or lower SPD")

    def stroke_range(self, value: Value, limits: FunLimits, span: Span, what: str) -> None:
        if isinstance(value, int) and not limits.stroke_min <= value <= limits.stroke_max:
            self.sink.add("E605", span, f"{what} {value} is outside {limits.stroke_min:,}.."
                          f"{limits.stroke_max:,} (PLC error 33)",
                          hint="FB 958" if limits.fun == 140 else "FB 2261-2262 (in Ps)")

    def drive(self, table: PositioningTable, limits: FunLimits, step: Step,
              motion: Drive) -> None:
        stroke_span = step.where("motion.stroke")
        self.stroke_range(motion.stroke, limits, stroke_span, f"{motion.op} stroke")
        self.variable(motion.stroke, 2, stroke_span, f"{motion.op} stroke", "32")
        dir_span = step.where("motion.dir")
        if motion.coord == "ABS" and motion.direction and motion.op == "DRV":
            self.sink.add("E610", dir_span, f"{motion.op} ABS takes no direction: the target "
                          "decides it", hint=f"write {motion.op} ABS,,target,{motion.unit} "
                          "(FB 911-918)")
        elif motion.op == "DRVC" and not motion.direction:
            self.sink.add("E610", dir_span, "DRVC needs the direction + or -",
                          hint="the chain's direction comes from '+' or '-' only (FB 978)")
        elif motion.direction and isinstance(motion.stroke, int) and motion.stroke < 0:
            self.sink.add("E610", stroke_span, f"a negative stroke with the direction "
                          f"'{motion.direction}'", hint="with + or - the stroke is unsigned; "
                          "leave the direction blank to let the sign decide (FB 891-898)")
        if motion.stroke == 0 and self.profile.zero_runs_on(motion.coord) and (
                step.condition is None or step.condition.op == "WAIT"):
            self.sink.add("W603", stroke_span, f"{motion.op} stroke 0 runs for ever (FB "
                          "955-957), and this step has no EXT or ACT to end it",
                          hint="end a continuous run with EXT contact or ACT TIME, or give a "
                          "stroke")

    def line(self, table: PositioningTable, limits: FunLimits, step: Step,
             motion: Line) -> None:
        moving = [s for s in motion.strokes if s is not None and
                  (motion.coord == "ABS" or s != 0)]
        if not moving:
            self.sink.add("E615", step.where("motion"), f"{motion.op} moves no axis (PLC "
                          "error 60)", hint="give at least one axis a stroke (ADR: blank or 0 "
                          "means no motion, FB 2253-2259)")
        for axis, stroke in enumerate(motion.strokes):
            if stroke is None:
                continue
            span = step.where(f"motion.axis{axis}")
            self.variable(stroke, 2, span, f"{motion.op} Ps{axis}", "32")
            if isinstance(stroke, int) and motion.op == "LIN":
                pulses = self.axis_params(axis).stroke_pulses(stroke, motion.unit)
                if not limits.stroke_min <= pulses <= limits.stroke_max:
                    self.sink.add("E605", span, f"LIN Ps{axis} {stroke} {motion.unit} is "
                                  f"{pulses:,} Ps, outside {limits.stroke_min:,}.."
                                  f"{limits.stroke_max:,} Ps (PLC error 33)",
                                  hint="one LIN moves an axis at most 1,999,999 Ps "
                                  "(FB 2261-2262)")
        if motion.op == "LINE" and (step.condition is None or step.condition.op == "WAIT"):
            self.sink.add("W603", step.where("motion"), "LINE runs until its exit condition is "
                          "met (FB 2282-2299), and this step has no EXT to end it",
                          hint="end a LINE step with EXT contact")

    def home(self, table: PositioningTable, step: Step, motion: Home) -> None:
        span = step.where("motion")
        if not 0 <= motion.mode <= 2:
            self.sink.add("E619", span, f"DRVZ MD{motion.mode} does not exist (PLC error 50)",
                          hint="modes MD0, MD1, MD2 (FB 1042-1046)")
            return
        if table.unit not in self.params:
            self.sink.add("E619", span, f"DRVZ needs the FUN141 table of Ps{table.unit}, and "
                          "the build has none", hint="add 'TABLE name FUN141 Ps"
                          f"{table.unit}' with parameter 15 (FB 3263-3267)")
            return
        params = self.axis_params(table.unit)
        limits = self.profile.drvz
        needs = [(0, "the DOG input (15-0)", limits["dog_max"], "X", 51, True),
                 (1, "the limit input (15-1)", limits["limit_max"], "X", 51, False),
                 (2, "the PG0 input (15-2)", limits["pg0_max"], "X", 52, motion.mode == 2),
                 (3, "the CLR output (15-3)", limits["clr_max"], "Y", 53, False)]
        for which, what, highest, kind, code, required in needs:
            raw = params.io_field(which)
            number = raw if which == 3 else raw & 0x7F
            if raw == 0xFF:
                if required:
                    self.sink.add("E619", span, f"DRVZ MD{motion.mode} needs {what} in FUN141 "
                                  f"parameter 15 of Ps{table.unit} (PLC error {code})",
                                  hint="see the table at FB 3269-3277")
            elif number > highest:
                self.sink.add("E619", span, f"{what} of Ps{table.unit} is {kind}{number}; "
                              f"it must be {kind}0-{kind}{highest} (PLC error {code})",
                              hint="FB 1664-1687, 3558")

    def condition(self, table: PositioningTable, limits: FunLimits, step: Step) -> None:
        condition = step.condition
        if condition is None:
            return
        span = step.where("condition.operand")
        if condition.op not in limits.instructions:
            code = 60 if table.fun == 147 else 43
            self.sink.add("E614", step.where("condition"), f"{condition.op} is not a "
                          f"FUN{table.fun} instruction (PLC error {code})",
                          hint="FUN147 transitions are WAIT and EXT (FB 2380)")
        if condition.time is not None:
            low, high = self.profile.time_range
            if isinstance(condition.time, int) and not low <= condition.time <= high:
                self.sink.add("E620", span, f"{condition.op} TIME {condition.time} is outside "
                              f"{low}..{high} (0.01 s)", hint="one register holds the time")
            self.variable(condition.time, 1, span, f"{condition.op} TIME")
        if condition.contact is not None:
            self.contact(condition.contact, span)

    def contact(self, contact: Contact, span: Span) -> None:
        highest = self.profile.contacts[contact.kind]
        if contact.number > highest:
            self.sink.add("E607", span, f"{contact} does not exist: {contact.kind}0-"
                          f"{contact.kind}{highest} (FB 1087-1093)")

    def transition(self, table: PositioningTable, index: int, step: Step) -> None:
        count = len(table.steps)
        span = step.where("goto")
        is_drvc = isinstance(step.motion, Drive) and step.motion.op == "DRVC"
        if isinstance(step.goto, int) and not 1 <= step.goto <= count:
            self.sink.add("E608", span, f"GOTO {step.goto}: {table.name!r} has steps 1-{count} "
                          "(PLC error 34)")
        elif isinstance(step.goto, Register):
            self.variable(step.goto, 1, span, "GOTO")
        elif step.goto == NEXT and index == count - 1 and not is_drvc:
            self.sink.add("W602", span, "GOTO NEXT in the last step: FB does not say where it "
                          "goes; the virtual controller wraps to step 1",
                          hint="write GOTO 1 or MEND")
        if step.goto is not None and step.condition is None and not is_drvc and \
                step.motion is not None:
            self.sink.add("W601", span, f"step {step.number} ends its "
                          f"{_op(step)} with a bare GOTO: FB prints that only for DRVC",
                          hint="write WAIT TIME,0 before the GOTO to keep to printed forms")
        if step.mend and step.condition is not None:
            self.sink.add("W601", span, f"step {step.number} has a condition and MEND: FB "
                          "never prints MEND after a condition", hint="end with GOTO instead")

    # ------------------------------------------------------------ DRVC chains
    def drvc_chains(self, table: PositioningTable) -> None:
        steps = table.steps
        index = 0
        while index < len(steps):
            step = steps[index]
            if not (isinstance(step.motion, Drive) and step.motion.op == "DRVC"):
                index += 1
                continue
            start = index
            while index < len(steps) and isinstance(steps[index].motion, Drive) and \
                    steps[index].motion.op == "DRVC":  # type: ignore[union-attr]
                link = steps[index]
                if link.condition is not None or link.mend or (
                        link.goto not in (NEXT, link.number + 1)):
                    self.sink.add("E613", link.where("goto"), f"DRVC step {link.number} must go "
                                  "straight on: no condition, GOTO NEXT",
                                  hint="a DRVC segment flows into the next step (FB 988-997)")
                if index > start and link.motion.coord == "ABS":  # type: ignore[union-attr]
                    self.sink.add("E609", link.where("motion.coord"), "only the first DRVC of a "
                                  "chain may use ABS (PLC error 41)", hint="FB 975-977")
                index += 1
            segments = index - start + 1
            if index >= len(steps):
                self.sink.add("E611", steps[index - 1].where("motion"), "a DRVC chain must end "
                              "with a DRV step, and the table ends first",
                              hint="the last segment is a DRV (FB 1013-1015)")
                continue
            last = steps[index]
            if isinstance(last.motion, Home):
                self.sink.add("E612", last.where("motion"), "DRVC cannot be followed by DRVZ "
                              "(PLC error 42)", hint="end the chain with a DRV first")
            elif not (isinstance(last.motion, Drive) and last.motion.op == "DRV"):
                self.sink.add("E611", last.span, "a DRVC chain must end with a DRV step",
                              hint="the last segment is a DRV (FB 1013-1015)")
            else:
                if last.motion.coord == "ABS":
                    self.sink.add("E609", last.where("motion.coord"), "only the first DRVC of a "
                                  "chain may use ABS; the closing DRV is part of the chain (PLC "
                                  "error 41)", hint="FB 975-977")
                if segments > self.profile.drvc_max_segments:
                    self.sink.add("E611", steps[start].where("motion"), f"a DRVC chain of "
                                  f"{segments} segments; at most "
                                  f"{self.profile.drvc_max_segments} (FB 974)",
                                  hint="split the chain with a stop")
            index += 1

    # ------------------------------------------------------------ overlaps
    def overlaps(self, tables: list[Table]) -> None:
        blocks: list[tuple[str, int, int, Span, str]] = []
        for table in tables:
            spans = [("table", table.sr, table_words(table, self.profile))]
            if isinstance(table, PositioningTable):
                spans.append(("work registers", table.wr,
                              self.profile.limits(table.fun).work_registers))
            for what, start, size in spans:
                if start is None:
                    continue
                label = f"{table.name!r} {what} {start}-{start.offset(size - 1)}"
                first, last = start.number, start.number + size - 1
                for kind, other_first, other_last, span, other in blocks:
                    if kind == start.kind and first <= other_last and other_first <= last:
                        self.sink.add("E617", table.span, f"{label} shares registers with "
                                      f"{other}",
                                      related=((span, other),), hint="registers of a program "
                                      "table or work area must not be reused (FB 532-534, "
                                      "1159)")
                        break
                blocks.append((start.kind, first, last, table.span, label))

    # ------------------------------------------------------------ SIM
    def sim(self, sim: SimSetup) -> None:
        for event in sim.events:
            self.contact(event.contact, event.span)
        for window in sim.windows:
            self.contact(window.contact, window.span)
        for pulse in sim.pulses:
            self.contact(pulse.contact, pulse.span)
        for register, span in sim.spans.items():
            if self.area_of(register, 1, (*self.profile.variable_areas,
                                          *self.profile.table_areas)) is None:
                self.sink.add("E606", span, f"SIM sets {register}, which is not a register of "
                              "the PLC areas mplang knows")


def _op(step: Step) -> str:
    motion = step.motion
    if isinstance(motion, Drive | Line):
        return motion.op
    return "DRVZ"
