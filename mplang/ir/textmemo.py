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
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

from mplang.ir.blockmemo import Statement, record, replay
from mplang.ir.macro import CallSite, MacroLine
from mplang.ir.reuse import NAMES_A_LINE
from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, Span, make_span

if TYPE_CHECKING:
    from mplang.ir.lower import ProgramLowerer

_CANDIDATES = 4
"""Lowerings kept per text (one per state it was entered in): a statement met in many
states (W103 of a variable written in some programs and not in others) is lowered afresh
beyond these."""


class TextMemo:
    """A build's top-level statements as lowered, by file, program context and text."""

    __slots__ = ("kept", "texts")

    def __init__(self, texts: dict[str, list[str]]) -> None:
        self.texts = texts  # each file's lines, by its display name (the spans' file)
        self.kept: dict[Hashable, list[Statement]] = {}

    def lower(self, node: ast.Node, lowerer: ProgramLowerer, context: Hashable,
              make: Callable[[ast.Node], bool]) -> bool:
        """Lower the top-level statement `node` in `lowerer` (`make` lowers it afresh), or
        replay a lowering of the same text in the same `context` (the program's kind and
        labels) that entered the present state; True if control never falls through it."""
        span = node.span
        first = span.line
        end = getattr(node, "end_span", None)
        last = end.line if isinstance(end, Span) else first
        lines = self.texts.get(span.file)
        if lines is None or not 0 < first <= last <= len(lines):
            return make(node)
        text = lines[first - 1] if first == last else tuple(lines[first - 1:last])
        key = (span.file, context, text)
        candidates = self.kept.get(key)
        if candidates is not None:
            for kept in candidates:
                if kept.enters(lowerer):
                    _replay_moved(kept, first - kept.node.span.line, lowerer)
                    return kept.jumps
        made = record(node, lowerer, make)
        if _stays_inside(made, span.file, first, last):
            if candidates is None:
                self.kept[key] = [made]
            elif len(candidates) < _CANDIDATES:
                candidates.append(made)
        return made.jumps


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


def _replay_moved(kept: Statement, offset: int, lowerer: ProgramLowerer) -> None:
    """Do to `lowerer` what lowering the kept statement did, `offset` lines further down."""
    if offset == 0:
        replay(kept, lowerer)
        return

    def move(span: Span) -> Span:
        return make_span(span.file, span.line + offset, span.col, span.end_col)

    lowerer.out.lines.extend([MacroLine(line.command, line.operands, move(line.span))
                              for line in kept.lines])
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
