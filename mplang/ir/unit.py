"""A `.mp` unit lowered to macro lines: what every family's back end starts from.

`Options` are the build settings a project or the command line gives (word order, target,
temporaries, variable pool, slot pins), `lower_unit` lowers every program and configuration
block of a declared unit in one path that the M8194H compiler, the other families' compilers
and the editor's budget display share.
"""

from __future__ import annotations

import contextlib

from mplang.ir.blockmemo import Statements
from mplang.ir.configure import (
    InitLowerer,
    InterruptWiring,
    TriggerTable,
    build_trigger_table,
    wire_interrupts,
)
from mplang.ir.lower import DEFAULT_VAR_POOL, ConstError, ProgramLowerer, Scope
from mplang.ir.macro import LoweredProgram
from mplang.ir.reuse import Lowerings, lowering_context
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.record import FrozenRecord, Record

DEFAULT_TEMPS = range(500, 512)


class SlotPin(FrozenRecord):
    """`name = "MP3"` in a project's `[slots]` table; `span` is that line of mpc.toml."""

    name: str
    kind: str
    slot: int
    span: Span
    _fields = __match_args__ = ("name", "kind", "slot", "span")

    def __init__(self, name: str, kind: str, slot: int, span: Span) -> None:
        self.__dict__.update(name=name, kind=kind, slot=slot, span=span)


class Options(FrozenRecord):
    """The build settings of a project or the command line; `replace` gives a changed copy
    (`dataclasses.replace` does not take a record)."""

    word_order: int | None  # None: the device default
    target: str  # "et" (ET-M8194H, TCP), "rs" (RS-M8194H, RTU), or another family's
    temps: range
    allow_outside_includes: bool
    pins: tuple[SlotPin, ...]  # slot pins of a project file (mpc.toml [slots])
    var_pool: range  # where unpinned `VAR name` declarations go
    _fields = __match_args__ = ("word_order", "target", "temps", "allow_outside_includes",
                                "pins", "var_pool")

    def __init__(self, word_order: int | None = None, target: str = "et",
                 temps: range = DEFAULT_TEMPS, allow_outside_includes: bool = False,
                 pins: tuple[SlotPin, ...] = (), var_pool: range = DEFAULT_VAR_POOL) -> None:
        self.__dict__.update(word_order=word_order, target=target, temps=temps,
                             allow_outside_includes=allow_outside_includes, pins=pins,
                             var_pool=var_pool)


def _lower_init(unit: ast.Unit, scope: Scope, sink: DiagnosticSink, target: str
                ) -> LoweredProgram | None:
    """The build's one INIT block, lowered (E801 for any further block)."""
    for extra in unit.inits[1:]:
        first = unit.inits[0]
        sink.add("E801", extra.span, f"a second INIT block (the first is at "
                 f"{first.span.file}:{first.span.line})", hint="merge them into one")
    if not unit.inits:
        return None
    return InitLowerer(scope, unit.inits[0], target).lower_init()


def configuration_blocks(unit: ast.Unit) -> list[tuple[str, Span]]:
    """("INIT" | "INTERRUPTS" | "TRIGGERS", header span) of every configuration block: the
    other families have no counterpart for them and must say so, never drop them."""
    blocks: list[tuple[str, Span]] = [("INIT", b.span) for b in unit.inits]
    blocks += [("INTERRUPTS", b.span) for b in unit.interrupts]
    blocks += [("TRIGGERS", b.span) for b in unit.triggers]
    return sorted(blocks, key=lambda item: (item[1].file, item[1].line))


class LoweredUnit(Record):
    """A build lowered up to the linker: programs (interrupt wiring injected), the INIT
    block, the wiring and the trigger table."""

    programs: list[LoweredProgram]
    init: LoweredProgram | None
    wiring: InterruptWiring
    triggers: TriggerTable | None
    _fields = __match_args__ = ("programs", "init", "wiring", "triggers")

    def __init__(self, programs: list[LoweredProgram], init: LoweredProgram | None,
                 wiring: InterruptWiring, triggers: TriggerTable | None) -> None:
        self.programs = programs
        self.init = init
        self.wiring = wiring
        self.triggers = triggers


def lower_unit(unit: ast.Unit, scope: Scope, sink: DiagnosticSink, options: Options,
               kept: Lowerings | None = None) -> LoweredUnit:
    """Every program and configuration block of a declared unit, lowered and checked: the
    one path the compiler and the editor's budget display share. `kept`, from the last
    build, gives each unchanged program its lowering from then (`mplang.ir.reuse`)."""
    catalogue = scope.catalogue
    names = {p.name.upper(): p for p in unit.programs if p.name}
    lowered: list[LoweredProgram] = []
    if kept is not None:
        kept.start(lowering_context(scope, names, options.temps, options.target))
    for program in unit.programs:
        def lower(statements: Statements | None = None, program: ast.Program = program
                  ) -> LoweredProgram | None:
            with contextlib.suppress(ConstError):  # already reported where it arose
                return ProgramLowerer(scope, program, options.temps, options.target,
                                      names).lower_program(statements)
            return None

        result = lower() if kept is None else kept.lower(program, scope, sink, lower)
        if result is not None:
            lowered.append(result)
    if kept is not None:
        kept.finish()
    init = _lower_init(unit, scope, sink, options.target)
    wiring = wire_interrupts(unit.interrupts, lowered, init, catalogue, sink, names)
    triggers = build_trigger_table(unit.triggers, catalogue, sink, names)
    return LoweredUnit(lowered, init, wiring, triggers)
