"""The M8194H compiler: `.mp` sources in, a download image (or diagnostics) out. The
sources are read, checked and lowered by the family-free layers (`mplang.lang`,
`mplang.ir.unit`); what is the M8194H's own is placing programs in slots (`link`) and
encoding macro lines as Modbus frames (`encode`)."""

from __future__ import annotations

import gc
from collections.abc import Callable
from functools import cache
from itertools import accumulate
from pathlib import Path

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.configure import TriggerTable, Wire
from mplang.ir.lower import Scope
from mplang.ir.macro import LoweredProgram, MacroLine, ProgramRef
from mplang.ir.persist import StoredLowerings, code_key
from mplang.ir.reuse import BuildMemo, Lowerings
from mplang.ir.textmemo import TextMemo
from mplang.ir.unit import DEFAULT_TEMPS, Options, lower_unit
from mplang.lang import ast, caches
from mplang.lang.diagnostics import DiagnosticSink, suppressed
from mplang.lang.followon import settle_includes
from mplang.lang.heap import collection_paused, in_mpc
from mplang.lang.linecache import StatementCache, text_lines
from mplang.lang.sources import SourceSet, load_sources
from mplang.lang.structure import build_unit, has_lone_cr
from mplang.m8194h.chipvalues import warn_changed
from mplang.m8194h.encode import Encoder
from mplang.m8194h.image import (
    IMAGE_FORMAT,
    BuildResult,
    InitImage,
    LineFrames,
    ProgramImage,
    TriggerImage,
)
from mplang.m8194h.link import Placement, link, resolve

__all__ = ["DEFAULT_TEMPS", "IMAGE_FORMAT", "BuildMemo", "BuildResult", "InitImage",
           "LineFrames", "Lowering", "Options", "ProgramImage", "TriggerImage", "compile_paths",
           "compile_source", "compile_sources"]


class Lowering:
    """What a build worked out on the way to its image, for a tool that shows more than the
    image from the same one pass (the language server: slot budgets, constant values). A
    slots class, not a dataclass: creating one at import costs every build command's start."""

    __slots__ = ("placements", "programs", "scope")

    def __init__(self, scope: Scope | None = None, programs: list[LoweredProgram] | None = None,
                 placements: list[Placement] | None = None) -> None:
        self.scope = scope
        self.programs: list[LoweredProgram] = [] if programs is None else programs
        self.placements: list[Placement] = [] if placements is None else placements


def compile_paths(paths: list[Path], options: Options = Options(), *,
                  texts: dict[Path, str] | None = None,
                  lines: StatementCache | None = None,
                  memo: BuildMemo | None = None) -> BuildResult:
    """Compile files (and their includes) together into one image; `lines`, kept between
    builds, parses only the lines it has not seen (`mplang.lang.linecache`), and `memo`,
    kept between builds of the same files, re-does only the programs an edit changed
    (`mplang.ir.reuse`)."""
    with collection_paused():  # mplang.lang.heap: a build makes no cycles
        sink = DiagnosticSink()
        sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                               texts=texts, lines=lines)
        result = compile_sources(paths, sources, sink, options, memo=memo)
        if memo is None:
            _freeze_first_build()
        _promote_build()
        return result


_froze_a_build = False


def _freeze_first_build() -> None:
    """In an `mpc` process, freeze what its first build made, as start-up is frozen
    (`mplang.lang.heap`): a command keeps its build until it ends, and the collection that
    follows the build (the collector on again, its counts grown by every object the build
    made) would walk all of them to free nothing, a build making no cycles: a sixth of
    `mpc build` of the full device. Once per process, as `heap` freezes (a test process
    runs many commands); never in a program that uses mplang as a library."""
    global _froze_a_build
    if not _froze_a_build and in_mpc():
        _froze_a_build = True
        gc.freeze()


def _promote_build() -> None:
    """Move what the build made to the collector's oldest generation, unwalked, when
    nothing is frozen: the collection that follows the build (the collector on again, its
    counts grown by every object the build made) would walk all of them to free nothing, a
    build making no cycles (a sixth of a whole device's build in a program using mplang as
    a library). Freezing and unfreezing at once is that move: it walks nothing, and the
    objects stay where a full collection finds them (a cycle one of them joins later is
    still freed), unlike a freeze (`_freeze_first_build`). Not when something is frozen
    (`mpc`: start-up is): unfreezing would thaw that too. An `mpc` process (the CLI
    imported: its language server, a test process running commands) is told by its
    modules, not by `gc.get_freeze_count()`, which counts the frozen objects one by one:
    13 ms a build under a language server's frozen heap."""
    if in_mpc():
        return
    if gc.get_freeze_count() == 0:  # a library user's heap: empty unless it froze its own
        gc.freeze()
        gc.unfreeze()


def compile_sources(paths: list[Path], sources: SourceSet, sink: DiagnosticSink,
                    options: Options = Options(), lowering: Lowering | None = None,
                    memo: BuildMemo | None = None, encode: bool = True) -> BuildResult:
    """`compile_paths` for sources already read into `sources` (their diagnostics in
    `sink`); `lowering`, when given, receives the scope, lowered programs and placements.
    `encode=False` checks only (an editor's diagnostics): the result holds no image."""
    catalogue = catalogue_module.load()
    texts = {f.display: text_lines(f.text) for f in sources.files}
    kept = memo.lowerings if memo is not None else _stored(texts)
    with collection_paused():
        unit = build_unit(sources, sink, memo.blocks if memo is not None else None)
        result = _finish(unit, catalogue, sink, options, lowering, kept, encode,
                         TextMemo(_memo_texts(sources, texts)))
    if isinstance(kept, StoredLowerings):
        kept.save()
    result.sources = {display: _split_lines(text, texts[display])
                      for display, text in {f.display: f.text for f in sources.files}.items()}
    if paths:
        first = paths[0].resolve()
        result.first_source = next((s for s in result.sources if Path(s).resolve() == first),
                                   None)
    # only a file with an `mpc: ignore` comment can silence anything: the thousands of
    # warnings of a whole device are not looked up line by line in the others
    marked = {f.display for f in sources.files if "mpc:" in f.text}
    result.diagnostics = settle_includes(
        [d for d in result.diagnostics
         if d.span.file not in marked or not suppressed(d, result.sources)] if marked
        else result.diagnostics, result.sources)
    return result


_OTHER_BREAKS = ("\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e")
"""What `str.splitlines` breaks an ASCII text at besides a line feed."""


def _split_lines(text: str, split: list[str]) -> list[str]:
    """`text.splitlines()`, taken from `split` (`text.split("\n")`, made already) when the
    line feeds are its only line boundaries: a few scans in C (an ASCII text knows it is
    one) instead of splitting a whole device's file again on every check."""
    if not text.isascii() or any(mark in text for mark in _OTHER_BREAKS):
        return text.splitlines()
    return split[:-1] if split[-1] == "" else split[:]


def _memo_texts(sources: SourceSet, texts: dict[str, list[str]]) -> dict[str, list[str]]:
    """The lines by which `ir.textmemo` may key the statements of each file, by the name
    its spans carry: not a file whose lines are not as the parse numbered them (a lone
    carriage return), nor a name two different texts share."""
    seen: dict[str, str] = {}
    clash: set[str] = set()
    for source in sources.files:
        if seen.setdefault(source.display, source.text) != source.text:
            clash.add(source.display)
    return {display: texts[display] for display, text in seen.items()
            if display not in clash and not has_lone_cr(text)}


def _stored(texts: dict[str, list[str]]) -> StoredLowerings | None:
    """The lowerings of a build without a memo (a command's one build): kept on disk
    between runs (`mplang.ir.persist`), unless caching is off. `texts`: each file's lines."""
    directory = caches.user_cache_dir()
    if directory is None:
        return None
    return StoredLowerings(directory, texts, _salt())


@cache
def _salt() -> str:
    """What a stored lowering depends on besides its program and context: the code that
    lowers, warns (W111) and encodes, and the catalogue it reads."""
    from importlib import import_module

    return code_key(Path(path) for name in ("mplang.ir", "mplang.lang", "mplang.m8194h",
                                            "mplang.stdlib.m8194h")
                    for path in import_module(name).__path__)


def compile_source(text: str, name: str = "<input>.mp", options: Options = Options()
                   ) -> BuildResult:
    """Compile one in-memory source (tests, editors)."""
    path = Path(name)
    return compile_paths([path], options, texts={path: text, path.resolve(): text})


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


def _finish(unit: object, catalogue: Catalogue, sink: DiagnosticSink,
            options: Options, lowering: Lowering | None = None,
            kept: Lowerings | None = None, encode: bool = True,
            text_memo: TextMemo | None = None) -> BuildResult:
    assert isinstance(unit, ast.Unit)
    profile = catalogue.profile
    word_order = profile.word_order_default if options.word_order is None else options.word_order
    scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
    scope.text_memo = text_memo
    lowered_unit = lower_unit(unit, scope, sink, options, kept)
    lowered, init = lowered_unit.programs, lowered_unit.init
    wiring, triggers = lowered_unit.wiring, lowered_unit.triggers
    placements = link(lowered, profile, sink, options.pins)
    if lowering is not None:
        lowering.scope, lowering.programs, lowering.placements = scope, lowered, placements
    by_name = {p.name.upper(): p for p in lowered if p.name}

    def slot_of(ref: ProgramRef) -> int | None:
        return resolve(ref, by_name)

    _check_filled(placements, wiring.all_wires, triggers, slot_of, sink)
    warn_changed(lowered, init, profile, sink, kept)
    result = BuildResult(sink.sorted(), word_order=word_order, target=options.target,
                         variables=sorted(scope.variables, key=lambda v: v.index),
                         aliases=list(scope.alias_names))
    if not encode or not result.ok:
        return result
    encoder = Encoder(catalogue, word_order)
    if init is not None:
        result.init = InitImage(init, [encoder.frame(line, slot_of) for line in init.lines])
    if triggers is not None:
        result.triggers = TriggerImage(triggers.source, triggers.span.line, [
            t.to_json(slot_of(t.mp) if t.mp is not None else None) for t in triggers.entries])

    encoded: dict[tuple[int, int], tuple[MacroLine, list[int]]] = {}
    for placement in sorted(placements, key=lambda p: (p.program.kind != "mp", p.slot)):
        program = placement.program
        frames = _frames(program, encoder, slot_of, kept, encoded)
        # each line's first slot line: the line costs before it, summed (one comprehension
        # per program, not a loop with an append per line: a whole device has thousands)
        # (`starts` has one more: the slot line after the last)
        assert len(frames) == len(program.lines)
        starts = accumulate([line.command.line_cost for line in program.lines], initial=0)
        lines = [LineFrames(line, start, frame)
                 for line, frame, start in zip(program.lines, frames, starts, strict=False)]
        result.programs.append(ProgramImage(
            placement, encoder.create_frame(program.kind, placement.slot), lines,
            encoder.close_frame(program.kind), program.end_span))
    return result


def _frames(program: LoweredProgram, encoder: Encoder,
            slot_of: Callable[[ProgramRef], int | None], kept: Lowerings | None,
            encoded: dict[tuple[int, int], tuple[MacroLine, list[int]]]) -> list[list[int]]:
    """The frames of a program's lines. A program lowered as in the last build (and given no
    lines by the wiring since) is encoded as then when the programs it names are in the same
    slots and the word order is the same: those are all a frame reads besides its line.
    `encoded`, one build's: lines that share their command and operands objects (a statement
    lowered once for several places, `mplang.ir.textmemo`) are encoded once."""
    entry = kept.entry(program) if kept is not None else None
    if entry is None or entry.result is None or len(entry.result.lines) != len(program.lines):
        return _fresh_frames(program.lines, encoder, slot_of, encoded)
    refs = entry.derived_for("refs", None, lambda: tuple(dict.fromkeys(
        o for line in program.lines for o in line.operands if isinstance(o, ProgramRef))))
    assert isinstance(refs, tuple)
    key = (encoder.word_order, tuple(slot_of(ref) for ref in refs))
    found = entry.derived_for("frames", key,
                              lambda: [encoder.frame(line, slot_of) for line in program.lines])
    assert isinstance(found, list)
    return [list(frame) for frame in found]


def _fresh_frames(lines: list[MacroLine], encoder: Encoder,
                  slot_of: Callable[[ProgramRef], int | None],
                  encoded: dict[tuple[int, int], tuple[MacroLine, list[int]]]
                  ) -> list[list[int]]:
    """`encoder.frame(line, slot_of)` of each line, once per command and operands objects in
    a build (its slots and word order are one): told by identity, the line kept beside its
    frame so that neither object is freed and its id taken by another while the build runs.
    One loop, no call per line: a whole device's lines are mostly found here."""
    frames: list[list[int]] = []
    append, found_of = frames.append, encoded.get
    for line in lines:
        command, operands = line.command, line.operands
        key = (id(command), id(operands))
        found = found_of(key)
        if found is not None and found[0].command is command and \
                found[0].operands is operands:
            append(list(found[1]))
            continue
        frame = encoder.frame(line, slot_of)
        encoded[key] = (line, frame)
        append(list(frame))
    return frames
