"""The preferred fixes of a file's diagnostics, applied: what `mpc lint --fix` writes and the
language server's `source.fixAll.mpc` code action offers.

A fix is the language server's preferred quick fix (`lsp.editing.quick_fixes`): the name a
did-you-mean hint suggests, spelled as its definition spells it. Suppressing a warning with
a comment is a quick fix too, but never a preferred one, so it is never applied here. Fixes
that overlap are applied one per pass; the file is re-checked between passes (a fix can
bring the next one to light), for at most `MAX_PASSES`, so a fix that undid another could
not loop for ever.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from mplang.tools.lsp.analysis import Analysis, analyse
from mplang.tools.lsp.editing import TextEdit, quick_fixes
from mplang.tools.lsp.positions import Pos, Range
from mplang.tools.lsp.workspace import BuildContext, context_for

MAX_PASSES = 8


@dataclass(frozen=True)
class Fixed:
    """A file's text after its preferred fixes, and how many were applied."""

    text: str
    applied: int


def _offsets(text: str) -> list[int]:
    """The offset of each line's start, lines split at "\n" as `split_lines` splits them
    (a CR before the LF stays part of its line here, so CRLF text keeps its endings)."""
    starts = [0]
    for line in text.split("\n")[:-1]:
        starts.append(starts[-1] + len(line) + 1)
    return starts


def apply_edits(text: str, edits: list[TextEdit]) -> str:
    """`text` with `edits` (ranges in code points, not overlapping) applied."""
    starts = _offsets(text)

    def offset(pos: Pos) -> int:
        if pos.line >= len(starts):
            return len(text)
        return min(starts[pos.line] + pos.character, len(text))

    for edit in sorted(edits, key=lambda e: (e.range.start, e.range.end), reverse=True):
        text = text[:offset(edit.range.start)] + edit.text + text[offset(edit.range.end):]
    return text


def preferred_edits(analysis: Analysis) -> list[TextEdit]:
    """The preferred fixes of every diagnostic of the analysed file, none overlapping
    another (the first, in file order, wins; the others wait for the next pass)."""
    everything = Range(Pos(0, 0), Pos(max(len(analysis.lines), 1), 0))
    chosen: list[TextEdit] = []
    for fix in sorted((f for f in quick_fixes(analysis, everything) if f.preferred),
                      key=lambda f: (f.edit.range.start, f.edit.range.end)):
        if chosen and fix.edit.range.start < chosen[-1].range.end:
            continue
        if chosen and fix.edit == chosen[-1]:
            continue
        chosen.append(fix.edit)
    return chosen


def fix_text(path: Path, text: str, context: BuildContext | None = None,
             open_texts: Mapping[Path, str] | None = None) -> Fixed:
    """`text`, the contents of `path`, with every preferred fix applied, checked as the
    language server checks it (the nearest mpc.toml's build, unless `context` is given)."""
    context = context or context_for(path)
    applied = 0
    for _ in range(MAX_PASSES):
        edits = preferred_edits(analyse(path, text, context, open_texts))
        if not edits:
            break
        changed = apply_edits(text, edits)
        if changed == text:
            break
        text, applied = changed, applied + len(edits)
    return Fixed(text, applied)
