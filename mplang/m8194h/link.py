"""The linker: slots for every program, budgets, and the static call graph.

Programs with a number keep it. A slot pin (the `[slots]` table of `mpc.toml`) gives an
unnumbered program its slot from outside the source, so that it stays put when other programs
grow (and an incremental flash rewrites only what changed). The remaining unnumbered ones go, in
source order, to the smallest free slot of their kind whose budget fits (ties: the lowest
number), so the same sources always give the same placement.
"""

from __future__ import annotations

from collections.abc import Callable

from mplang.ir.catalogue import Profile
from mplang.ir.macro import CallSite, LoweredProgram, ProgramRef
from mplang.ir.unit import SlotPin
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.record import Record


class Placement(Record):
    program: LoweredProgram
    slot: int
    lines_used: int
    budget: int
    auto: bool
    _fields = __match_args__ = ("program", "slot", "lines_used", "budget", "auto")

    def __init__(self, program: LoweredProgram, slot: int, lines_used: int, budget: int,
                 auto: bool) -> None:
        self.program = program
        self.slot = slot
        self.lines_used = lines_used
        self.budget = budget
        self.auto = auto


def _range_text(profile: Profile, kind: str, lines: int) -> str:
    for rng in profile.slots:
        if rng.kind == kind and rng.lines == lines:
            return f"{kind.upper()}{rng.first}-{kind.upper()}{rng.last}"
    return kind.upper()


def _fitting_hint(profile: Profile, kind: str, needed: int, pinned: bool = False) -> str:
    """What to do about a program too big for its slot; `pinned`: the slot is an mpc.toml
    pin, not a number in the source."""
    bigger = [r for r in profile.slots if r.kind == kind and r.lines >= needed]
    if not bigger:
        return "split it into several programs that CALL each other"
    best = min(bigger, key=lambda r: r.lines)
    slots = f"{kind.upper()}{best.first}-{kind.upper()}{best.last} ({best.lines} lines)"
    if pinned:
        return f"pin it to a slot in {slots}, remove the pin to let the linker choose, or " \
               "split it"
    return f"use a slot in {slots}, drop the number to let the linker choose, or split it"


def link(programs: list[LoweredProgram], profile: Profile, sink: DiagnosticSink,
         pins: tuple[SlotPin, ...] = ()) -> list[Placement]:
    close = profile.close_counts_as_line
    taken: dict[tuple[str, int], LoweredProgram] = {}
    placements: list[Placement] = []
    names: dict[str, LoweredProgram] = {}
    for program in programs:
        if program.name:
            key = program.name.upper()
            if key in names:
                sink.add("E505", program.span, f"a program named {program.name!r} already "
                         "exists", related=((names[key].span, "first definition"),))
            else:
                names[key] = program
    pinned = _apply_pins(pins, names, profile, sink)
    for program in programs:
        if program.slot is None:
            continue
        budget = profile.budget(program.kind, program.slot)
        if budget is None:
            top = max(profile.slot_numbers(program.kind))
            sink.add("E501", program.span, f"{program.kind.upper()}{program.slot} does not "
                     f"exist: slots are {program.kind.upper()}1..{program.kind.upper()}{top}")
            continue
        slot_key = (program.kind, program.slot)
        if slot_key in taken:
            sink.add("E502", program.span, f"{program.kind.upper()}{program.slot} is already "
                     "taken", related=((taken[slot_key].span, "first program in this slot"),),
                     hint="give one of them another number, or none")
            continue
        taken[slot_key] = program
        used = program.lines_used(close)
        if used > budget:
            detail = " including the closing line" if close else ""
            pin = pinned.get(id(program))
            # a slot an mpc.toml pin gave: the pin's line is what to change
            sink.add("E503", program.span if pin is None else pin.span,
                     f"{program.label} needs {used} lines{detail}, but "
                     f"{_range_text(profile, program.kind, budget)} slots hold {budget}",
                     hint=_fitting_hint(profile, program.kind, used, pin is not None),
                     related=() if pin is None else ((program.span, "the program"),))
        placements.append(Placement(program, program.slot, used, budget, auto=False))
    for program in programs:
        if program.slot is not None:
            continue
        used = program.lines_used(close)
        free = [(profile.budget(program.kind, n) or 0, n)
                for n in profile.slot_numbers(program.kind) if (program.kind, n) not in taken]
        fitting = sorted((lines, n) for lines, n in free if lines >= used)
        if not fitting:
            sink.add("E504", program.span, f"no free {program.kind.upper()} slot holds "
                     f"{program.label}'s {used} lines",
                     hint=_fitting_hint(profile, program.kind, used))
            continue
        budget, slot = fitting[0]
        taken[(program.kind, slot)] = program
        program.slot = slot
        placements.append(Placement(program, slot, used, budget, auto=True))
    _check_calls(placements, names, profile, sink)
    return placements


def _apply_pins(pins: tuple[SlotPin, ...], names: dict[str, LoweredProgram],
                profile: Profile, sink: DiagnosticSink) -> dict[int, SlotPin]:
    """Give pinned programs their slot, as if the source had numbered them; the pins that
    gave one, by the program's id."""
    given: dict[int, SlotPin] = {}
    for pin in pins:
        label = f"{pin.kind.upper()}{pin.slot}"
        program = names.get(pin.name.upper())
        if program is None:
            sink.add("W109", pin.span, f"the slot pin {pin.name} = {label} names no program "
                     "of this build", hint="remove the pin, or add the file that defines "
                     f"{pin.name} to the sources")
            continue
        if program.kind != pin.kind:
            sink.add("E506", pin.span, f"{pin.name} is an {program.kind.upper()}, but its pin "
                     f"is the {pin.kind.upper()} slot {label}",
                     related=((program.span, f"{pin.name} is defined here"),),
                     hint=f"pin it to an {program.kind.upper()} slot")
            continue
        if profile.budget(pin.kind, pin.slot) is None:
            top = max(profile.slot_numbers(pin.kind))
            sink.add("E501", pin.span, f"{label} does not exist: slots are "
                     f"{pin.kind.upper()}1..{pin.kind.upper()}{top}")
            continue
        if program.slot is not None:
            if program.slot != pin.slot:
                sink.add("E506", pin.span, f"{pin.name} is pinned to {label}, but its source "
                         f"numbers it {program.kind.upper()}{program.slot}",
                         related=((program.span, "numbered here"),),
                         hint="keep one of the two: the number in the source or the pin")
            continue
        program.slot = pin.slot
        given[id(program)] = pin
    return given


def resolve(ref: ProgramRef, names: dict[str, LoweredProgram]) -> int | None:
    if ref.slot is not None:
        return ref.slot
    target = names.get(ref.name or "")
    return target.slot if target else None


def _check_calls(placements: list[Placement], names: dict[str, LoweredProgram],
                 profile: Profile, sink: DiagnosticSink) -> None:
    by_slot = {p.slot: p.program for p in placements if p.program.kind == "mp"}
    edges: dict[int, list[tuple[int, CallSite]]] = {}
    for placement in placements:
        program = placement.program
        if program.kind != "mp":
            continue
        for site in program.calls:
            slot = resolve(site.target, names)
            if slot is None:
                continue
            if slot not in by_slot:
                sink.add("W105", site.span, f"MP{slot} is not part of this build",
                         hint="make sure it is already on the device")
                continue
            edges.setdefault(placement.slot, []).append((slot, site))
    limit = profile.limit("call_depth")
    depth_memo: dict[int, int] = {}
    reported: set[int] = set()
    recurse: dict[str, Callable[[int, list[int]], int]] = {}  # cleared after: no cycle

    def depth(slot: int, path: list[int]) -> int:
        """Levels of programs from `slot` down (1 = calls nothing); cycles report E432."""
        if slot in depth_memo:
            return depth_memo[slot]
        if slot in path:
            return 0
        best = 1
        for callee, site in edges.get(slot, []):
            if callee in path or callee == slot:
                if slot not in reported:
                    reported.add(slot)
                    cycle = [*path[path.index(callee):], slot, callee] if callee in path \
                        else [slot, callee]
                    sink.add("E432", site.span, "recursive CALL: " + " -> ".join(
                        f"MP{n}" for n in cycle),
                        hint="the device has no recursion; use a loop instead")
                continue
            best = max(best, 1 + recurse["depth"](callee, [*path, slot]))
        depth_memo[slot] = best
        return best

    recurse["depth"] = depth
    for slot in sorted(edges):
        levels = depth(slot, [])
        if levels > limit and slot not in reported:
            reported.add(slot)
            program = by_slot[slot]
            sink.add("E433", program.span, f"MP{slot} starts a chain of {levels} nested "
                     f"programs; the device allows {limit}",
                     hint="flatten the call chain")
    recurse.clear()  # depth reached itself through it: no cycle keeps the programs
