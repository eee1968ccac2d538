"""Writing a FATEK build out: the native listing (`fbs`), a WinProladder-style listing with
register spans and source lines (`listing`), the register table layout (`table`) and JSON.

The register table gives exactly what FB documents: the header words (A55AH / A55CH and the
step count, FB 684-686, 1997-1999), the size of every step (9 or 15 registers, FB 575, 1889)
and the whole FUN141 table (FB 1461-1503). FB prints no encoding for the words inside a step,
so those words are written as undefined (`????` in text, null in JSON), never guessed.
"""

from __future__ import annotations

from typing import Any

from mplang.fatek.check import table_words
from mplang.fatek.model import (
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
    split32,
)
from mplang.fatek.profile import Profile

UNDEFINED = "????"
STEP_WORDS_NOTE = ("FB documents no encoding for the words of a step (no opcode, flag or "
                   "operand layout is printed in chapter 11); they are left undefined")


def address(table: Table, offset: int) -> str:
    """`R5003` when the table's SR is known, `SR+3` otherwise."""
    if table.sr is None:
        return f"SR+{offset}"
    return str(table.sr.offset(offset))


def register_span(table: Table, first: int, count: int) -> str:
    if count == 1:
        return address(table, first)
    return f"{address(table, first)}-{address(table, first + count - 1)}"


def steps_text(count: int) -> str:
    return f"{count} step{'' if count == 1 else 's'}"


def step_offset(table: PositioningTable, profile: Profile, index: int) -> int:
    limits = profile.limits(table.fun)
    return limits.header_words + limits.words_per_step * index


def _header(table: Table) -> str:
    if isinstance(table, ParamTable):
        words = [f"TABLE {table.name} FUN141 Ps{table.axis}"]
    else:
        words = [f"TABLE {table.name} FUN{table.fun} {table.unit_name}"]
    if table.sr is not None:
        words.append(f"SR={table.sr}")
    if isinstance(table, PositioningTable) and table.wr is not None:
        words.append(f"WR={table.wr}")
    return " ".join(words)


def _step_lines(step: Step, width: int) -> list[str]:
    out = []
    for index, text in enumerate(step.lines()):
        prefix = f"{step.number:03d} " if index == 0 else "    "
        out.append(f"{prefix}{text}")
    if step.note and out:
        out[0] = f"{out[0]:<{width}} ; {step.note}"
    return out


def render_fbs(tables: list[Table], sim: SimSetup, title: str, profile: Profile) -> str:
    """The native listing: it parses back to the same tables."""
    lines = [f"; {title}"]
    for table in tables:
        lines.append("")
        lines.append(_header(table))
        if isinstance(table, ParamTable):
            for number, value in sorted(table.values.items()):
                spec = profile.param(number)
                lines.append(f"P{number} = {spec.text(value) if spec else value}")
            continue
        for step in table.steps:
            lines += _step_lines(step, 28)
    if not sim.is_empty():
        lines.append("")
        lines += sim_lines(sim)
    return "\n".join(lines) + "\n"


def sim_lines(sim: SimSetup) -> list[str]:
    out = []
    for register, value in sorted(sim.registers.items()):
        out.append(f"SIM {register} = {value}")
    for event in sim.events:
        out.append(f"SIM {event.contact} {'ON' if event.state else 'OFF'} AT {event.time:g}")
    for window in sim.windows:
        out.append(f"SIM {window.contact} ON WHILE Ps{window.axis} IN "
                   f"{window.low}..{window.high}")
    for pulse in sim.pulses:
        out.append(f"SIM {pulse.contact} PULSE Ps{pulse.axis} EVERY {pulse.every}")
    return out


def render_listing(tables: list[Table], profile: Profile) -> str:
    """Per table and step: the registers the step occupies, where it came from, its text."""
    out: list[str] = []
    for table in tables:
        words = table_words(table, profile)
        rows: list[tuple[str, str, str]] = []  # registers, source place, text
        if isinstance(table, ParamTable):
            out.append(f"FUN141 table {table.name!r} (Ps{table.axis}): {words} registers "
                       f"{register_span(table, 0, words)}")
            for number, value in sorted(table.values.items()):
                spec = profile.param(number)
                if spec is None:
                    continue
                span = table.spans.get(number)
                where = f"{span.file}:{span.line}" if span is not None else ""
                rows.append((register_span(table, spec.offset, spec.words), where,
                             f"P{number} = {spec.text(value)}  ({spec.name})"))
        else:
            limits = profile.limits(table.fun)
            wr = f", WR={table.wr}" if table.wr is not None else ""
            out.append(f"FUN{table.fun} table {table.name!r} ({table.unit_name}{wr}): "
                       f"{steps_text(len(table.steps))}, {words} registers "
                       f"{register_span(table, 0, words)}")
            rows.append((register_span(table, 0, limits.header_words), "",
                         f"header: {limits.flag:04X}H, {steps_text(len(table.steps))}"))
            for index, step in enumerate(table.steps):
                regs = register_span(table, step_offset(table, profile, index),
                                     limits.words_per_step)
                for line_no, text in enumerate(step.lines()):
                    span = _part_span(step, text)
                    label = f"{step.number:03d} " if line_no == 0 else "    "
                    rows.append((regs if line_no == 0 else "", f"{span.file}:{span.line}",
                                 label + text))
        first = max((len(r[0]) for r in rows), default=0)
        second = max((len(r[1]) for r in rows), default=0)
        out += [f"  {regs:<{first}}  {where:<{second}}  {text}".rstrip()
                for regs, where, text in rows]
        out.append("")
    return "\n".join(out)


def _part_span(step: Step, text: str) -> Any:
    head = text.split(None, 1)[0]
    key = {"SPD": "speed", "GOTO": "goto", "MEND": "mend", "WAIT": "condition",
           "ACT": "condition", "EXT": "condition"}.get(head, "motion")
    return step.where(key)


def render_table(tables: list[Table], profile: Profile) -> str:
    """The register table layout: documented words exactly, undocumented ones marked."""
    out = [f"; Register table layout. {STEP_WORDS_NOTE}: '{UNDEFINED}'."]
    for table in tables:
        out.append("")
        words = table_words(table, profile)
        if isinstance(table, ParamTable):
            out.append(f"; FUN141 table {table.name!r}, Ps{table.axis}: {words} registers "
                       f"{register_span(table, 0, words)} (FB 1411-1414, 1461-1503)")
            for offset, value, text in param_words(table, profile):
                out.append(f"{address(table, offset):<8} {value:04X}H  {text}")
            continue
        limits = profile.limits(table.fun)
        lines = "FB 684-686, 1156-1157" if table.fun == 140 else "FB 1997-1999, 2399-2400"
        out.append(f"; FUN{table.fun} table {table.name!r}, {table.unit_name}: "
                   f"{steps_text(len(table.steps))} x {limits.words_per_step} + "
                   f"{limits.header_words} = {words} registers "
                   f"{register_span(table, 0, words)} ({lines})")
        out.append(f"{address(table, 0):<8} {limits.flag:04X}H  flag: a valid FUN{table.fun} "
                   "program")
        out.append(f"{address(table, 1):<8} {len(table.steps) & 0xFFFF:04X}H  total steps "
                   f"({len(table.steps)})")
        for index, step in enumerate(table.steps):
            first = step_offset(table, profile, index)
            regs = register_span(table, first, limits.words_per_step)
            text = " / ".join(step.lines())
            out.append(f"{regs:<17} {UNDEFINED} x{limits.words_per_step}  step {step.number}: "
                       f"{text}")
    return "\n".join(out) + "\n"


def param_words(table: ParamTable, profile: Profile) -> list[tuple[int, int, str]]:
    """The 24 registers of a FUN141 table: (offset, word, what it holds)."""
    rows: list[tuple[int, int, str]] = []
    for spec in profile.params:
        value = table.values.get(spec.number, spec.default)
        given = "" if spec.number in table.values else " (default)"
        if spec.words == 1:
            rows.append((spec.offset, value & 0xFFFF,
                         f"parameter {spec.number} {spec.name} = {spec.text(value)}{given}"))
        else:
            low, high = split32(value)
            rows.append((spec.offset, low, f"parameter {spec.number} {spec.name} = "
                         f"{spec.text(value)}{given}, low word"))
            rows.append((spec.offset + 1, high, f"parameter {spec.number}, high word"))
    return sorted(rows)


def table_image(table: Table, profile: Profile) -> list[int | None]:
    """Every register of the table: documented words as numbers, undefined ones as None."""
    if isinstance(table, ParamTable):
        words: list[int | None] = [0] * profile.fun141_words
        for offset, value, _ in param_words(table, profile):
            words[offset] = value
        return words
    limits = profile.limits(table.fun)
    return [limits.flag, len(table.steps)] + [None] * (limits.words_per_step * len(table.steps))


# ---------------------------------------------------------------- JSON
def value_json(value: Value | None) -> int | str | None:
    if isinstance(value, Register):
        return str(value)
    return value


def step_json(step: Step, table: PositioningTable, profile: Profile, index: int
              ) -> dict[str, Any]:
    limits = profile.limits(table.fun)
    motion: dict[str, Any] | None = None
    if isinstance(step.motion, Drive):
        motion = {"op": step.motion.op, "coord": step.motion.coord,
                  "direction": step.motion.direction, "stroke": value_json(step.motion.stroke),
                  "unit": step.motion.unit}
    elif isinstance(step.motion, Line):
        motion = {"op": step.motion.op, "coord": step.motion.coord,
                  "strokes": [value_json(s) for s in step.motion.strokes],
                  "unit": step.motion.unit}
    elif isinstance(step.motion, Home):
        motion = {"op": "DRVZ", "mode": step.motion.mode}
    condition = None
    if step.condition is not None:
        condition = {"op": step.condition.op, "time": value_json(step.condition.time),
                     "contact": str(step.condition.contact) if step.condition.contact else None}
    goto: int | str | None = value_json(step.goto) if not isinstance(step.goto, str) \
        else step.goto
    return {
        "number": step.number, "source": step.span.file, "line": step.span.line,
        "registers": register_span(table, step_offset(table, profile, index),
                                   limits.words_per_step),
        "text": step.lines(), "speed": value_json(step.speed), "motion": motion,
        "condition": condition, "goto": goto, "mend": step.mend,
    }


def table_json(table: Table, profile: Profile) -> dict[str, Any]:
    base: dict[str, Any] = {"name": table.name, "source": table.source,
                            "line": table.span.line,
                            "sr": str(table.sr) if table.sr is not None else None,
                            "registers": table_words(table, profile),
                            "words": table_image(table, profile)}
    if isinstance(table, ParamTable):
        return {"kind": "fun141", "axis": table.axis, **base,
                "params": {str(k): v for k, v in sorted(table.values.items())}}
    return {"kind": f"fun{table.fun}", table.unit_name[:2].lower(): table.unit, **base,
            "wr": str(table.wr) if table.wr is not None else None,
            "steps": [step_json(s, table, profile, i) for i, s in enumerate(table.steps)]}
