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
from mplang.tools.lsp import analysis as analysis_module
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


def test_a_files_index_is_kept_only_while_what_it_read_is_the_same() -> None:
    """The definitions, blocks and labels of a file are taken from its last check when the
    statements they were read from are the very same objects on lines of the same text (an
    edit of a command line), and read again otherwise: a label renamed, a line added after
    an unclosed program (its last line moves), a CONST changed. Each time the analysis is
    the one a fresh check makes."""
    path = Path("/indexed.mp")
    lines = ["CONST FAST = 5", "MP 1 first", "    VAR1 = 1", "LABEL top", "    GOTO top",
             "END MP", "MP 2 open", "    VAR2 = FAST"]
    memo, statements = BuildMemo(), StatementCache()
    previous = analyse(path, "\n".join(lines), lines=statements, memo=memo)
    edits = [(2, "    VAR1 = 2"), (3, "LABEL again"), (8, ""), (0, "CONST FAST = 6"),
             (7, "    VAR2 = FAST + 1")]
    for row, text in edits:
        if row == len(lines):
            lines.append(text)
        else:
            lines[row] = text
        joined = "\n".join(lines)
        index = analysis_module._indexes[(path.resolve(), True)]
        previous = analyse(path, joined, lines=statements, memo=memo, previous=previous)
        kept = analysis_module._indexes[(path.resolve(), True)]
        assert (kept is index) == (row in (2, 7))  # the command lines
        assert _seen(previous) == _seen(analyse(path, joined))
        analysis_module._indexes[(path.resolve(), True)] = kept  # the server's, not the fresh
        label = lines[3].split()[1].upper()
        assert [(p.first_line, p.last_line, sorted(p.labels)) for p in previous.programs] == \
            [(1, 5, [label]), (6, len(lines) - 1, [])]


def test_a_diagnostic_of_an_included_file_is_placed_again_on_its_include(tmp_path: Path
                                                                          ) -> None:
    """A diagnostic of an INCLUDEd file is shown on the INCLUDE line, placed from no line of
    its own: kept by identity (the file is unchanged), its placement is still made again
    when the edit moved the INCLUDE's path along its line (the line count unchanged), as a
    fresh analysis places it."""
    (tmp_path / "lib.mp").write_text("MP 2 helper\n    VAR9 = VAR10\nEND MP\n")
    path = tmp_path / "main.mp"
    lines = ["# the main file", 'INCLUDE "lib.mp"', "MP 1 first", "    VAR1 = 1", "END MP",
             ""]
    memo, statements = BuildMemo(), StatementCache()
    first = analyse(path, "\n".join(lines), lines=statements, memo=memo)
    shown = [d for d in first.diagnostics if d.elsewhere]
    assert shown and shown[0].range.start.character == 8
    lines[1] = '   INCLUDE    "lib.mp"'
    edited = analyse(path, "\n".join(lines), lines=statements, memo=memo, previous=first)
    assert edited.raw[0] is first.raw[0]  # the very diagnostic, kept with its file's program
    assert edited.diagnostics == analyse(path, "\n".join(lines)).diagnostics
    assert [d.range.start.character for d in edited.diagnostics if d.elsewhere] == [14]


def _fresh(path: Path, text: str) -> Analysis:
    """An analysis from scratch that leaves the kept file indexes as they were, so that the
    next analysis of an edit finds its own last index (as the server's would)."""
    kept = dict(analysis_module._indexes)
    analysis_module._indexes.clear()
    try:
        return analyse(path, text)
    finally:
        analysis_module._indexes.clear()
        analysis_module._indexes.update(kept)


def _edits_index_as_afresh(path: Path, first: list[str], texts: list[list[str]]) -> None:
    """Analyse `first`, then each text from the last, and compare each with a fresh one."""
    lines, memo = StatementCache(), BuildMemo()
    previous = analyse(path, "\n".join(first), lines=lines, memo=memo)
    for text in texts:
        joined = "\n".join(text)
        previous = analyse(path, joined, lines=lines, memo=memo, previous=previous)
        assert _seen(previous) == _seen(_fresh(path, joined))


@edit_sequences
def test_random_edits_index_the_edited_lines_as_a_fresh_analysis_does(
        path: Path, steps: list[tuple[int, int, int]]) -> None:
    """Edits analysed each from the last, nothing else analysing the file between: an edit
    that keeps the count of lines has its file's index look only at the statements of
    the edited lines, the others taken where the last index found them. Each analysis is
    the one made from scratch."""
    texts = [path.read_text(encoding="utf-8").split("\n")]
    for step in steps:
        texts.append(changed(texts[-1], step))
    _edits_index_as_afresh(path, texts[0], texts[1:])


@large_edit_sequences
def test_random_edits_inside_one_program_index_the_edited_lines_as_afresh(
        steps: list[tuple[int, int, int]]) -> None:
    """The same inside one long program and across its blocks' boundaries (labels, block
    openers and closers put in and taken out)."""
    texts = [list(LARGE_WARM_UP[-1])]
    for step in steps:
        texts.append(changed_large(texts[-1], step))
    _edits_index_as_afresh(Path("/large.mp"), texts[0], texts[1:])
