"""The language server's incremental analysis: with the statement cache, the build memo and
the document's previous analysis, as the server passes them, every edit of a random
sequence gives exactly the analysis of the same text checked from scratch (diagnostics as
placed, definitions, program blocks, slot budgets, constants). The server's own
(tests/tools/lsp/test_sync_server.py) is compared with a fresh server's publish."""

from __future__ import annotations

from pathlib import Path

from hypothesis import example, given, settings
from hypothesis import strategies as st
from sourceedits import CHECKS, ROOT, SAMPLES, STEPS, changed

from mplang.ir.reuse import BuildMemo
from mplang.lang.linecache import StatementCache
from mplang.tools.lsp.analysis import Analysis, analyse


def _seen(analysis: Analysis) -> tuple[object, ...]:
    return (analysis.diagnostics, analysis.consts, analysis.const_values, analysis.aliases,
            analysis.declared, analysis.programs, analysis.slot_uses, analysis.includes,
            analysis.variables_used)


@settings(max_examples=50, deadline=None)
@given(path=st.sampled_from(SAMPLES) | st.sampled_from(CHECKS), steps=STEPS)
@example(path=ROOT / "samples" / "expressions.mp", steps=[(5, 0, 0), (5, 1, 1)])  # CONSTs
@example(path=ROOT / "samples" / "pick_and_place.mp", steps=[(5, 2, 0), (0, 40, 1)])
@example(path=ROOT / "samples" / "call_chain.mp", steps=[(2, 0, 0)])  # every program moves up
@example(path=ROOT / "samples" / "pick_and_place.mp", steps=[(3, 0, 7), (3, 5, 9), (2, 1, 0)])
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

