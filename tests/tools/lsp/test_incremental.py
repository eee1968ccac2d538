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
