"""The library API: sources in, image (or diagnostics) out. The CLI is a thin shell over this."""

from __future__ import annotations

import contextlib
import hashlib
import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.configure import (
    InitLowerer,
    InterruptWiring,
    TriggerTable,
    Wire,
    build_trigger_table,
    wire_interrupts,
)
from mplang.ir.lower import DEFAULT_VAR_POOL, ConstError, ProgramLowerer, Scope, Variable
from mplang.ir.macro import LoweredProgram, MacroLine, ProgramRef
from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span
from mplang.lang.sources import load_sources
from mplang.lang.structure import build_unit
from mplang.m8194h.encode import Encoder
from mplang.m8194h.link import Placement, SlotPin, link, resolve

IMAGE_FORMAT = "mplang-image/1"
# `# mpc: ignore[W107]` (or `# mpc: ignore` for every warning) on a line silences warnings
# reported on that line. Errors cannot be silenced: the device would reject the program.
SUPPRESS = re.compile(r"mpc:\s*ignore(?:\[([A-Za-z0-9,\s]+)\])?")
DEFAULT_TEMPS = range(500, 512)


@dataclass(frozen=True)
class Options:
    word_order: int | None = None  # None: the device default
    target: str = "et"  # "et" (ET-M8194H, TCP) or "rs" (RS-M8194H, RTU)
    temps: range = DEFAULT_TEMPS
    allow_outside_includes: bool = False
    pins: tuple[SlotPin, ...] = ()  # slot pins of a project file (mpc.toml [slots])
    var_pool: range = DEFAULT_VAR_POOL  # where unpinned `VAR name` declarations go


@dataclass
class LineFrames:
    """One macro line as downloaded: where it came from and where it sits in the slot."""

    line: MacroLine
    first_slot_line: int  # 0-based, as the device's wLineNo counts
    frame: list[int]


@dataclass
class ProgramImage:
    placement: Placement
    create: list[int]
    lines: list[LineFrames]
    close: list[int]
    close_span: Span

    @property
    def program(self) -> LoweredProgram:
        return self.placement.program

    @property
    def frames(self) -> list[list[int]]:
        return [self.create, *(lf.frame for lf in self.lines), self.close]

    @property
    def frame_lines(self) -> list[int]:
        """The source line of each frame in `source` (create: the MP/ISR line, close: its END
        line), so a device's refusal can be traced back to the source from the image alone."""
        return [self.program.span.line, *(lf.line.span.line for lf in self.lines),
                self.close_span.line]

    def to_json(self) -> dict[str, object]:
        program = self.program
        return {
            "kind": program.kind, "slot": self.placement.slot, "name": program.name,
            "source": program.source, "lines_used": self.placement.lines_used,
            "budget": self.placement.budget, "auto_placed": self.placement.auto,
            "frame_lines": self.frame_lines, "frames": self.frames,
        }


@dataclass
class InitImage:
    """The INIT block as downloaded: real-time frames (INITIAL_* axis codes), LOAD_INITIAL
    last. Not a macro program: no slot, no budget."""

    program: LoweredProgram
    frames: list[list[int]]

    def to_json(self) -> dict[str, object]:
        return {"source": self.program.source, "line": self.program.span.line,
                "frame_lines": [line.span.line for line in self.program.lines],
                "frames": self.frames}


@dataclass
class TriggerImage:
    """The stand-alone trigger table with program slots resolved (chapter 10)."""

    source: str
    line: int
    entries: list[dict[str, object]]
    enabled: bool = True

    def to_json(self) -> dict[str, object]:
        return {"enabled": self.enabled, "source": self.source, "line": self.line,
                "entries": self.entries}


@dataclass
class BuildResult:
    diagnostics: list[Diagnostic]
    programs: list[ProgramImage] = field(default_factory=list)
    word_order: int = 0
    target: str = "et"
    sources: dict[str, list[str]] = field(default_factory=dict)  # display name -> lines
    variables: list[Variable] = field(default_factory=list)  # `VAR name` declarations
    init: InitImage | None = None  # the INIT block
    triggers: TriggerImage | None = None  # the TRIGGERS table

    @property
    def ok(self) -> bool:
        return not any(d.severity.value == "error" for d in self.diagnostics)

    def build_id(self) -> str:
        """Content hash of what would be downloaded: the same image, the same id."""
        digest = hashlib.sha256()
        content: list[object] = [self.word_order, [p.frames for p in self.programs]]
        if self.init is not None:
            content.append({"init": self.init.frames})
        if self.triggers is not None:
            content.append({"triggers": self.triggers.to_json()["entries"]})
        digest.update(json.dumps(content).encode())
        return digest.hexdigest()[:16]

    def image(self) -> dict[str, object]:
        image: dict[str, object] = {
            "format": IMAGE_FORMAT,
            "target": {"word_order": self.word_order, "family": "M8194H",
                       "variant": self.target},
            "build_id": self.build_id(),
        }
        if self.init is not None:
            image["init"] = self.init.to_json()
        if self.triggers is not None:
            image["triggers"] = self.triggers.to_json()
        image["programs"] = [p.to_json() for p in self.programs]
        return image


def compile_paths(paths: list[Path], options: Options = Options(), *,
                  texts: dict[Path, str] | None = None) -> BuildResult:
    """Compile files (and their includes) together into one image."""
    catalogue = catalogue_module.load()
    sink = DiagnosticSink()
    sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                           texts=texts)
    unit = build_unit(sources, sink)
    result = _finish(unit, catalogue, sink, options)
    result.sources = {f.display: f.text.splitlines() for f in sources.files}
    result.diagnostics = [d for d in result.diagnostics if not suppressed(d, result.sources)]
    return result


def suppressed(diagnostic: Diagnostic, sources: dict[str, list[str]]) -> bool:
    """`# mpc: ignore[CODE]` (or `# mpc: ignore`) on its line silences a warning; used by
    every family's checks, so the comment works the same in .mp, .fbs and .csim files."""
    if diagnostic.severity is not Severity.WARNING:
        return False
    lines = sources.get(diagnostic.span.file, [])
    if not 0 < diagnostic.span.line <= len(lines):
        return False
    match = SUPPRESS.search(lines[diagnostic.span.line - 1])
    if match is None:
        return False
    codes = match.group(1)
    return codes is None or diagnostic.code in {c.strip().upper() for c in codes.split(",")}


def compile_source(text: str, name: str = "<input>.mp", options: Options = Options()
                   ) -> BuildResult:
    """Compile one in-memory source (tests, editors)."""
    path = Path(name)
    return compile_paths([path], options, texts={path: text, path.resolve(): text})


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


def _check_filled(placements: list[Placement], wired: list[Wire],
                  triggers: TriggerTable | None, slot_of: Callable[[ProgramRef], int | None],
                  sink: DiagnosticSink) -> None:
    """W811/W821: interrupts and triggers that start a slot no program of the build fills
    (known only after linking, since unnumbered programs are placed then)."""
    filled = {(p.program.kind, p.slot) for p in placements}
    warned: set[tuple[str, int]] = set()
    for wire in wired:
        if not isinstance(wire.isr, int):
            continue  # an ISR named in the build
        isr = ("isr", wire.isr)
        if isr not in filled and isr not in warned:
            sink.add("W811", wire.span, f"ISR{wire.isr} is not in this build: the "
                     "interrupt starts an empty slot unless it is downloaded separately")
            warned.add(isr)
    for trigger in triggers.entries if triggers else []:
        number = slot_of(trigger.mp) if trigger.mp is not None else None
        mp = ("mp", number or 0)
        if number is not None and mp not in filled and mp not in warned:
            sink.add("W821", trigger.span, f"MP{number} is not in this build: the trigger "
                     "starts an empty slot unless it is downloaded separately")
            warned.add(mp)


def configuration_blocks(unit: ast.Unit) -> list[tuple[str, Span]]:
    """("INIT" | "INTERRUPTS" | "TRIGGERS", header span) of every configuration block: the
    other families have no counterpart for them and must say so, never drop them."""
    blocks: list[tuple[str, Span]] = [("INIT", b.span) for b in unit.inits]
    blocks += [("INTERRUPTS", b.span) for b in unit.interrupts]
    blocks += [("TRIGGERS", b.span) for b in unit.triggers]
    return sorted(blocks, key=lambda item: (item[1].file, item[1].line))


@dataclass
class LoweredUnit:
    """A build lowered up to the linker: programs (interrupt wiring injected), the INIT
    block, the wiring and the trigger table."""

    programs: list[LoweredProgram]
    init: LoweredProgram | None
    wiring: InterruptWiring
    triggers: TriggerTable | None


def lower_unit(unit: ast.Unit, scope: Scope, sink: DiagnosticSink, options: Options
               ) -> LoweredUnit:
    """Every program and configuration block of a declared unit, lowered and checked: the
    one path the compiler and the editor's budget display share."""
    catalogue = scope.catalogue
    names = {p.name.upper(): p for p in unit.programs if p.name}
    lowered: list[LoweredProgram] = []
    for program in unit.programs:
        with contextlib.suppress(ConstError):  # already reported where it arose
            lowered.append(ProgramLowerer(scope, program, options.temps, options.target,
                                          names).lower_program())
    init = _lower_init(unit, scope, sink, options.target)
    wiring = wire_interrupts(unit.interrupts, lowered, init, catalogue, sink, names)
    triggers = build_trigger_table(unit.triggers, catalogue, sink, names)
    return LoweredUnit(lowered, init, wiring, triggers)


def _finish(unit: object, catalogue: Catalogue, sink: DiagnosticSink,
            options: Options) -> BuildResult:
    assert isinstance(unit, ast.Unit)
    profile = catalogue.profile
    word_order = profile.word_order_default if options.word_order is None else options.word_order
    scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
    lowered_unit = lower_unit(unit, scope, sink, options)
    lowered, init = lowered_unit.programs, lowered_unit.init
    wiring, triggers = lowered_unit.wiring, lowered_unit.triggers
    placements = link(lowered, profile, sink, options.pins)
    by_name = {p.name.upper(): p for p in lowered if p.name}

    def slot_of(ref: ProgramRef) -> int | None:
        return resolve(ref, by_name)

    _check_filled(placements, wiring.all_wires, triggers, slot_of, sink)
    result = BuildResult(sink.sorted(), word_order=word_order, target=options.target,
                         variables=sorted(scope.variables, key=lambda v: v.index))
    if not result.ok:
        return result
    encoder = Encoder(catalogue, word_order)
    if init is not None:
        result.init = InitImage(init, [encoder.frame(line, slot_of) for line in init.lines])
    if triggers is not None:
        result.triggers = TriggerImage(triggers.source, triggers.span.line, [
            t.to_json(slot_of(t.mp) if t.mp is not None else None) for t in triggers.entries])

    for placement in sorted(placements, key=lambda p: (p.program.kind != "mp", p.slot)):
        program = placement.program
        line_no = 0
        lines: list[LineFrames] = []
        for line in program.lines:
            lines.append(LineFrames(line, line_no, encoder.frame(line, slot_of)))
            line_no += line.command.line_cost
        result.programs.append(ProgramImage(
            placement, encoder.create_frame(program.kind, placement.slot), lines,
            encoder.close_frame(program.kind), program.end_span))
    return result
