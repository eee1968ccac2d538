"""What a build keeps for the next one, so that an edit re-does only the program it changed.

A long-running caller (the language server) keeps one `BuildMemo` per document and passes
it to every build of it. Parsing already reuses unchanged lines (`lang.linecache`); here
the later passes do the same per program:

- matching blocks (`lang.structure.BlockMemo`): a program whose statements are unchanged is
  the same `ast.Program` object as last time, with the diagnostics it had;
- lowering (`Lowerings`): a program lowers to the same macro lines and diagnostics when it is
  unchanged (the same object, or equal: same statements at the same place) and so is all it
  reads of the rest of the build, the `context`: the CONSTs' values, the ALIASes and
  declared variables as placed, the names and kinds of the build's programs, the options
  and the catalogue. A change of the context drops every lowering;
- what a back end derives from one lowered program alone (the M8194H's W111 warnings and
  frames) is kept beside it (`Lowered.derived_for`), for the last key (what else it read);
- inside a program that changed, its top-level statements that did not
  (`ir.blockmemo.Statements`, kept with its lowering): a statement lowers as it did when it
  is unchanged and enters the state it entered then;
- a program that only moved (lines inserted or deleted above it: `BlockMemo.moved`) takes
  what it kept with every line shifted (`Lowered.moved`): its macro lines' origins, its
  diagnostics and derived diagnostics. Unless one of them names a line in its text
  ("unreachable: line 12 ...") or a place outside the program: it is then lowered again.

Declarations, variable placement, interrupt wiring, triggers and linking are whole-build
passes and run every time: they are cheap, and linking must see every program.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Hashable

from mplang.ir.blockmemo import Chunk, Statement, Statements, derived_for
from mplang.ir.macro import CallSite, LoweredProgram, MacroLine
from mplang.ir.scope import Scope
from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Run, Span, make_span
from mplang.lang.structure import BlockMemo

NAMES_A_LINE = re.compile(r"\blines? \d|:\d")
"""A line number in a diagnostic's text ("of line 12", "first at a.mp:12"): such a text
is not shifted with its span, so its program is lowered again when it moves."""


class _Unmovable(Exception):
    """A kept lowering holds a place that does not move with its program."""


class _Shift:
    """Spans of one file's lines `first`..`last` moved by `offset` lines."""

    def __init__(self, file: str, first: int, last: int, offset: int) -> None:
        self.file, self.first, self.last, self.offset = file, first, last, offset
        self.pairs: list[tuple[Diagnostic, Diagnostic]] = []  # (shifted, kept)

    def span(self, span: Span) -> Span:
        if span.file != self.file or not self.first <= span.line <= self.last:
            raise _Unmovable
        return make_span(span.file, span.line + self.offset, span.col, span.end_col)

    def diagnostic(self, item: Diagnostic) -> Diagnostic:
        texts = [item.message, item.hint, *(note for _, note in item.related)]
        if any(NAMES_A_LINE.search(text) for text in texts):
            raise _Unmovable
        made = Diagnostic(item.code, item.severity, item.message, self.span(item.span),
                          item.hint, tuple((self.span(s), note) for s, note in item.related))
        self.pairs.append((made, item))
        return made

    def derived(self, value: object) -> object:
        """A derived value as the moved program has it: a list of diagnostics is shifted;
        anything else holds no line (frames, the programs a program names)."""
        if isinstance(value, list) and value and all(isinstance(d, Diagnostic)
                                                     for d in value):
            return Run(map(self.diagnostic, value))
        return value


class Lowered:
    """One program's lowering as kept: None when a CONST it uses has no value (the program
    is then left out of the build, as a fresh lowering leaves it out). A slots class, not a
    dataclass: creating one at import costs every build command's start."""

    __slots__ = ("derived", "diagnostics", "program", "result", "statements")

    def __init__(self, program: ast.Program, result: LoweredProgram | None,
                 diagnostics: list[Diagnostic],
                 derived: dict[str, tuple[Hashable, object]] | None = None,
                 statements: Statements | None = None) -> None:
        self.program = program
        self.result = result
        self.diagnostics = diagnostics
        self.derived: dict[str, tuple[Hashable, object]] = {} if derived is None else derived
        # its top-level statements as lowered (`ir.blockmemo`): None for a lowering shifted
        self.statements = statements

    def segments(self) -> list[tuple[Statement | Chunk, int, int]] | None:
        """Each top-level statement (or chunk of them) of the program with its part of the
        macro lines (first, end), for a back end that derives per statement; None if
        unknown."""
        if self.statements is None or self.result is None:
            return None
        return self.statements.segments(self.result.lines)

    def derived_for(self, kind: str, key: Hashable, make: Callable[[], object]) -> object:
        """What a back end derives from this lowering (`kind`: "W111", "frames", ...) for
        `key`, what else it read: kept for the last key only, so that a program kept
        through many edits of what it does not contain keeps one of each."""
        return derived_for(self.derived, kind, key, make)

    def moved(self, program: ast.Program, offset: int,
              shifted: dict[int, tuple[Diagnostic, Diagnostic, int]] | None = None
              ) -> Lowered | None:
        """This lowering as `program`, the same program `offset` lines further down (up,
        below zero), has it: every kept span shifted. None when something kept does not
        move with the program (a line number in a text, a place outside it). `shifted`
        receives each shifted diagnostic by id: (it, the kept one, the offset)."""
        old = self.program
        shift = _Shift(old.span.file, old.span.line, old.end_span.line, offset)
        try:
            result = self.result
            if result is not None:
                result = LoweredProgram(
                    result.kind, result.slot, result.name, result.source,
                    shift.span(result.span), shift.span(result.end_span),
                    [MacroLine(line.command, line.operands, shift.span(line.span))
                     for line in result.lines],
                    [CallSite(call.target, shift.span(call.span)) for call in result.calls])
            made = Lowered(program, result, Run(map(shift.diagnostic, self.diagnostics)),
                           {kind: (key, shift.derived(value))
                            for kind, (key, value) in self.derived.items()})
        except _Unmovable:
            return None
        if shifted is not None:
            for new, kept in shift.pairs:
                shifted[id(new)] = (new, kept, offset)
        return made

    def copy(self) -> LoweredProgram | None:
        """The lowered program for one build (`LoweredProgram.copied`)."""
        return None if self.result is None else self.result.copied()


Context = tuple[object, ...]


def lowering_context(scope: Scope, names: dict[str, ast.Program], temps: range,
                     target: str) -> Context:
    """Everything a program's lowering reads besides the program: if it is equal, so is the
    lowering of an unchanged program. Names are kept in order (hints list them)."""
    return (scope.catalogue, temps, target, tuple(scope.const_exprs),
            tuple(scope.const_values.items()), tuple(scope.aliases.items()),
            frozenset(scope.declared_indices),
            tuple((name, p.kind, p.slot) for name, p in names.items()))


class Lowerings:
    """Programs lowered in the last build, by the span of their header."""

    def __init__(self, blocks: BlockMemo | None = None) -> None:
        self.blocks = blocks  # tells the programs that only moved
        self.context: Context | None = None
        self._now: dict[Span, Lowered] = {}
        self._before: dict[Span, Lowered] = {}
        self.origin: dict[int, Lowered] = {}  # id of this build's copy -> its entry
        # this build's diagnostics shifted from a kept one: id -> (it, the kept one, offset),
        # so that an editor moves what it made of the kept one (`tools.lsp.analysis`)
        self.shifted: dict[int, tuple[Diagnostic, Diagnostic, int]] = {}

    def start(self, context: Context) -> None:
        """A build begins: lowerings made under another context are dropped."""
        if context != self.context:
            self._before.clear()
            self._now.clear()
            self.context = context
        self.origin = {}
        self.shifted = {}

    def lower(self, program: ast.Program, scope: Scope, sink: DiagnosticSink,
              lower: Callable[[Statements | None], LoweredProgram | None]
              ) -> LoweredProgram | None:
        """The program's lowering for this build: kept, or made by `lower` with its
        diagnostics caught on their way to `sink` and kept with it. `lower` is given the
        statements kept at the program's place (from its first edit on), so that an edit
        inside a program lowers again only the statements it changed."""
        before = kept = self._now.get(program.span) or self._before.get(program.span)
        if kept is None or not (kept.program is program or kept.program == program):
            kept = self._moved(program)
        if kept is None:
            # a program lowered for the first time keeps no statements: most programs of a
            # long-lived document are never edited, and every kept object is more for the
            # collector to walk; the first edit of one starts its table
            statements = None if before is None else before.statements or Statements()
            own = DiagnosticSink()
            shared, scope.sink = scope.sink, own
            try:
                result = lower(statements)
            finally:
                scope.sink = shared
            kept = Lowered(program, result, Run(own.items), statements=statements)
        self._now[program.span] = kept
        sink.extend(kept.diagnostics)
        copy = kept.copy()
        if copy is not None:
            self.origin[id(copy)] = kept
        return copy

    def _moved(self, program: ast.Program) -> Lowered | None:
        """The kept lowering of the program `program` was before it moved, shifted."""
        found = self.blocks.moved.get(id(program)) if self.blocks is not None else None
        if found is None or found[0] is not program:
            return None
        _, old, offset = found
        for table in (self._before, self._now):
            kept = table.get(old.span)
            if kept is not None and kept.program is old:
                return kept.moved(program, offset, self.shifted)
        return None

    def recall(self, span: Span) -> Lowered | None:
        """What this build keeps for the program headed at `span`, if anything yet."""
        return self._now.get(span)

    def keep(self, lowered: Lowered) -> None:
        """Give this build a lowering kept elsewhere (on disk: `mplang.ir.persist`): `lower`
        takes it for its program, as one it kept itself."""
        self._now[lowered.program.span] = lowered

    def entry(self, program: LoweredProgram) -> Lowered | None:
        """The kept entry a lowered program of this build was copied from."""
        return self.origin.get(id(program))

    def finish(self) -> None:
        """A build is over: what it did not use is forgotten."""
        self._before, self._now = self._now, {}


class BuildMemo:
    """What one document's builds keep for the next (see the module's docstring). Not
    thread-safe: one per document of a server, used from its event loop. A slots class, as
    `Lowered`."""

    __slots__ = ("blocks", "lowerings")

    def __init__(self, blocks: BlockMemo | None = None,
                 lowerings: Lowerings | None = None) -> None:
        self.blocks = BlockMemo() if blocks is None else blocks
        self.lowerings = Lowerings() if lowerings is None else lowerings
        if self.lowerings.blocks is None:
            self.lowerings.blocks = self.blocks
