"""The language server's incremental analysis: with the statement cache, the build memo and
the document's previous analysis, as the server passes them, every edit of a random
sequence gives exactly the analysis of the same text checked from scratch (diagnostics as
placed, definitions, program blocks, slot budgets, constants). The server's own
(tests/tools/lsp/test_sync_server.py) is compared with a fresh server's publish."""

from __future__ import annotations

from pathlib import Path

from sourceedits import LARGE_WARM_UP, changed, changed_large, edit_sequences, large_edit_sequences

from mplang.ir.reuse import BuildMemo
from mplang.lang.linecache import StatementCache
from mplang.tools.lsp.analysis import Analysis, analyse


def _seen(analysis: Analysis) -> tuple[object, ...]:
    return (analysis.diagnostics, analysis.consts, analysis.const_values, analysis.aliases,
            analysis.declared, analysis.programs, analysis.slot_uses, analysis.includes,
            analysis.variables_used)


@edit_sequences
def test_random_edits_analyse_as_a_fresh_analysis_does(path: Path,
                                                       steps: list[tuple[int, int, int]]
                                                       ) -> None:
    lines, memo = StatementCache(), BuildMemo()
    text = path.read_text(encoding="utf-8").split("\n")
    previous = analyse(path, "\n".join(text), lines=lines, memo=memo)
    assert _seen(previous) == _seen(analyse(path, "\n".join(text)))
    for step in steps:
        text = changed(text, step)
        joined = "\n".join(text)
        previous = analyse(path, joined, lines=lines, memo=memo, previous=previous)
        assert _seen(previous) == _seen(analyse(path, joined))



@large_edit_sequences
def test_random_edits_inside_one_program_analyse_as_a_fresh_analysis_does(
        steps: list[tuple[int, int, int]]) -> None:
    """Edits inside one long program and across its blocks' boundaries, analysed as the
    server does (statements of the program kept between edits): each is the analysis from
    scratch."""
    path = Path("/large.mp")
    lines, memo = StatementCache(), BuildMemo()
    previous = None
    for text in LARGE_WARM_UP:
        previous = analyse(path, "\n".join(text), lines=lines, memo=memo, previous=previous)
        assert _seen(previous) == _seen(analyse(path, "\n".join(text)))
    text = list(LARGE_WARM_UP[-1])
    for step in steps:
        text = changed_large(text, step)
        joined = "\n".join(text)
        previous = analyse(path, joined, lines=lines, memo=memo, previous=previous)
        assert _seen(previous) == _seen(analyse(path, joined))


def test_a_kept_diagnostic_keeps_its_placement_only_while_its_line_is_unchanged() -> None:
    """The diagnostics the last analysis placed that are the very objects again keep their
    placements as they stand in the list (no object read), but one on a line the edit
    changed (here its comment: the statement and so the diagnostic stay the same) is
    placed again from its new line, as a fresh analysis places it."""
    path = Path("/kept.mp")
    lines = ["MP 1 first", "    VAR7 = VAR8", "END MP", "MP 2 second",
             "    VAR9 = VAR10 # note", "END MP", ""]
    memo, statements = BuildMemo(), StatementCache()
    first = analyse(path, "\n".join(lines), lines=statements, memo=memo)
    lines[4] = "    VAR9 = VAR10 # a longer note"
    edited = analyse(path, "\n".join(lines), lines=statements, memo=memo, previous=first)
    assert [d.code for d in edited.diagnostics] == ["W103", "W103"]
    assert edited.diagnostics == analyse(path, "\n".join(lines)).diagnostics
    assert edited.diagnostics[0] is first.diagnostics[0]  # its line is as it was
    assert edited.diagnostics[1] is not first.diagnostics[1]  # placed again
    lines[0:0] = ["# a line above every program"]
    moved = analyse(path, "\n".join(lines), lines=statements, memo=memo, previous=edited)
    assert moved.diagnostics == analyse(path, "\n".join(lines)).diagnostics
    assert [d.range.start.line for d in moved.diagnostics] == [2, 5]
