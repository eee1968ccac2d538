"""One build lowers each distinct top-level statement text once per lowering state.

A whole device repeats its lines a great deal (the same IF block in program after program),
and the parse already parses each distinct line once (`mplang.lang.linecache`). Lowering
does the same here: a top-level statement of a program (a line, or a whole FOR / IF / WHILE
/ REPEAT block with everything inside it) whose lines' texts are those of one lowered
earlier in the same build and file, in a program of the same kind with the same label
numbers, gives what that one gave, every span moved to its own lines, when it enters the
state that one entered (`blockmemo.Statement.enters`: the free temporaries, the labels left
for WHILE loops, whether the line before returns a value (W106), and for each variable whose
read it checked, whether it was written and warned about (W103)).

The texts are a sound key for the statement: the grammar is one statement per line, a
line's statements are a function of its text alone (their place moves only their spans),
and a top-level block's matching is a function of its lines from its opening to its closing
(`mplang.lang.structure`, whose depth count starts at the program's level for every one of
them). What the rest of the build gives a lowering (the CONSTs, ALIASes and variables, the
names of the programs, the options and the catalogue) is one for the whole build, and the
table lives for one build (one `Scope`). A statement is not shared when what its lowering
gave holds a place outside its own lines (a CONST's error, reported at the CONST), names a
line in a text, or when its expression was too deep to lower (E107).

Runs of statements repeat too (a whole device's programs start alike), so the statements
from every `CHUNK`-th one of a program's body on are also kept as one chunk
(`blockmemo.Chunk`), by the texts of all their lines: the texts from a top-level statement's
first line on fix the top-level statements they make, as for one statement. A chunk is kept
only when each of its statements was, and only its last one jumps (a W101 inside it would
name a line); it is replayed whole where it enters the state it entered.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

from mplang.ir.blockmemo import CHUNK, Chunk, Statement, record, replay
from mplang.ir.macro import CallSite, MacroLine
from mplang.ir.reuse import NAMES_A_LINE
from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, Run, Span, make_span

if TYPE_CHECKING:
    from mplang.ir.lower import ProgramLowerer

_CANDIDATES = 4
"""Lowerings kept per text (one per state it was entered in): a statement met in many
states (W103 of a variable written in some programs and not in others) is lowered afresh
beyond these."""


class Recording:
    """A chunk of top-level statements being lowered one by one (`TextMemo.chunk`), to be
    kept by the texts of its lines when every one of them was kept by its own and only
    the last one jumps (`TextMemo.keep_chunk`)."""

    __slots__ = ("calls", "count", "first", "jumped", "key", "lines", "reported",
                 "statements")

    def __init__(self, key: Hashable, first: int, count: int, lowerer: ProgramLowerer
                 ) -> None:
        self.key, self.first, self.count = key, first, count
        self.lines, self.calls = len(lowerer.out.lines), len(lowerer.out.calls)
        self.reported = len(lowerer.sink.items)
        self.statements: list[Statement] = []
        self.jumped = False

    def add(self, statement: Statement | None, jumps: bool) -> bool:
        """Note the next statement as lowered (None: not kept); False when the chunk can
        no longer be kept (a statement not kept, or one after a jump)."""
        if statement is None or self.jumped:
            return False
        self.statements.append(statement)
        self.jumped = jumps
        return True


class TextMemo:
    """A build's top-level statements as lowered, by file, program context and text; and
    chunks of them (`blockmemo.Chunk`: up to `CHUNK` consecutive ones from a multiple of
    `CHUNK` in their program's body) by the texts of all their lines, so that a program
    whose statements repeat another's in runs replays a run with one lookup."""

    __slots__ = ("chunks", "kept", "last", "texts")

    def __init__(self, texts: dict[str, list[str]]) -> None:
        self.texts = texts  # each file's lines, by its display name (the spans' file)
        self.kept: dict[Hashable, list[Statement]] = {}
        self.chunks: dict[Hashable, list[tuple[Chunk, int]]] = {}  # with their first line
        self.last: Statement | None = None  # the kept lowering `lower` used last, if any

    def chunk(self, body: list[ast.Node], index: int, lowerer: ProgramLowerer,
              context: Hashable) -> tuple[Chunk | None, Recording | None]:
        """The chunk of `body` from `index` on, replayed into `lowerer` when one of the same
        texts in the same `context` entered the present state (it, None); else (None, its
        recording), or (None, None) when it cannot be keyed by its texts."""
        end = min(index + CHUNK, len(body))
        if end - index < 2:
            return None, None
        span = body[index].span
        first = span.line
        last = _last_line(body[end - 1])
        lines = self.texts.get(span.file)
        if lines is None or not 0 < first <= last <= len(lines):
            return None, None
        key = (span.file, context, tuple(lines[first - 1:last]))
        candidates = self.chunks.get(key)
        if candidates is not None:
            for kept, base in candidates:
                if kept.enters(lowerer):
                    _replay_moved(kept, first - base, lowerer)
                    return kept, None
            if len(candidates) >= _CANDIDATES:
                return None, None
        return None, Recording(key, first, end - index, lowerer)

    def keep_chunk(self, recording: Recording, lowerer: ProgramLowerer) -> None:
        """Keep a chunk whose statements were all lowered (or replayed) and kept one by
        one: its state as they compose (`Chunk`), and what they emitted here."""
        if len(recording.statements) != recording.count:
            return
        made = Chunk(recording.statements)
        made.lines = lowerer.out.lines[recording.lines:]
        made.calls = tuple(lowerer.out.calls[recording.calls:])
        reported = lowerer.sink.items[recording.reported:]
        made.diagnostics = Run(reported) if reported else ()
        self.chunks.setdefault(recording.key, []).append((made, recording.first))

    def lower(self, node: ast.Node, lowerer: ProgramLowerer, context: Hashable,
              make: Callable[[ast.Node], bool]) -> bool:
        """Lower the top-level statement `node` in `lowerer` (`make` lowers it afresh), or
        replay a lowering of the same text in the same `context` (the program's kind and
        labels) that entered the present state; True if control never falls through it."""
        span = node.span
        first = span.line
        last = _last_line(node)
        lines = self.texts.get(span.file)
        self.last = None
        if lines is None or not 0 < first <= last <= len(lines):
            return make(node)
        text = lines[first - 1] if first == last else tuple(lines[first - 1:last])
        key = (span.file, context, text)
        candidates = self.kept.get(key)
        if candidates is not None:
            for kept in candidates:
                if kept.enters(lowerer):
                    _replay_moved(kept, first - kept.node.span.line, lowerer)
                    self.last = kept
                    return kept.jumps
        made = record(node, lowerer, make)
        if _stays_inside(made, span.file, first, last):
            self.last = made
            if candidates is None:
                self.kept[key] = [made]
            elif len(candidates) < _CANDIDATES:
                candidates.append(made)
        return made.jumps


def _last_line(node: ast.Node) -> int:
    """The last line of a top-level statement (a block's closing line)."""
    end = getattr(node, "end_span", None)
    return end.line if isinstance(end, Span) else node.span.line


def _stays_inside(made: Statement, file: str, first: int, last: int) -> bool:
    """Whether every place `made` holds is on its own lines and no text of its
    diagnostics names a line: only then is it the same at another place, moved."""
    def inside(span: Span) -> bool:
        return span.file == file and first <= span.line <= last

    for item in made.diagnostics:
        if item.code == "E107" or not inside(item.span) or \
                not all(inside(s) for s, _ in item.related) or \
                any(NAMES_A_LINE.search(text)
                    for text in (item.message, item.hint, *(n for _, n in item.related))):
            return False
    return all(inside(line.span) for line in made.lines) and \
        all(inside(call.span) for call in made.calls)


def _replay_moved(kept: Statement | Chunk, offset: int, lowerer: ProgramLowerer) -> None:
    """Do to `lowerer` what lowering the kept statement (chunk) did, `offset` lines
    further down."""
    if offset == 0:
        replay(kept, lowerer)
        return

    def move(span: Span) -> Span:
        return make_span(span.file, span.line + offset, span.col, span.end_col)

    # the lines' spans moved inline (no call of `move`): a whole device replays most of its
    # lines, and a call per line was a fifth of this function
    lowerer.out.lines.extend([
        MacroLine(line.command, line.operands, make_span(
            span.file, span.line + offset, span.col, span.end_col))
        for line in kept.lines for span in [line.span]])
    if kept.calls:
        lowerer.out.calls.extend([CallSite(call.target, move(call.span))
                                  for call in kept.calls])
    if kept.diagnostics:
        lowerer.sink.extend([Diagnostic(d.code, d.severity, d.message, move(d.span), d.hint,
                                        tuple((move(s), note) for s, note in d.related))
                             for d in kept.diagnostics])
    lowerer.written |= kept.writes
    lowerer.warned_reads |= kept.warned
    lowerer.free_temps[:] = kept.free_after
    lowerer.spare_labels[:] = kept.spare_after
