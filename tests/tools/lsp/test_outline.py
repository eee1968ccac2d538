"""Symbols, folding, semantic tokens and signature help over an `Analysis`, without pygls
(`mplang.tools.lsp.outline`). The server glue is tested over stdio in test_editing_server.py."""

from __future__ import annotations

import random
from pathlib import Path

from hypothesis import example, given, settings
from hypothesis import strategies as st

from mplang.tools.lsp import outline
from mplang.tools.lsp.analysis import Analysis, analyse
from mplang.tools.lsp.positions import Pos

CONTROLLER = Path(__file__).resolve().parents[3] / "samples" / "controller" / "controller.mp"

LOOPS = """# a loop
# and another
MP 1 loops
    WHILE VAR1 < 10
        REPEAT 3
            VAR1 = VAR1 + 1
        END REPEAT
    END WHILE
    FOR 2
        IF VAR1 > 3
            EXIT FOR
        END IF
    END FOR
END MP
MP 2 unclosed
    IF VAR1 > 3
        SET_V X, 1
"""


def check(tmp_path: Path, text: str) -> Analysis:
    path = tmp_path / "main.mp"
    path.write_text(text)
    return analyse(path, text)


def test_folding_of_loops_conditions_and_unclosed_blocks(tmp_path: Path) -> None:
    folds = outline.folding_ranges(check(tmp_path, LOOPS))
    assert [(f.first, f.last, f.kind) for f in folds] == [
        (0, 1, "comment"), (2, 13, "region"), (3, 7, "region"), (4, 6, "region"),
        (8, 12, "region"), (9, 11, "region"),
        # an unclosed program and IF run to the end of the file
        (14, 17, "region"), (15, 17, "region")]


def test_configuration_blocks_fold_and_are_symbols() -> None:
    analysis = analyse(CONTROLLER, CONTROLLER.read_text())
    lines = analysis.lines
    symbols = {s.name: s for s in outline.document_symbols(analysis)}
    init = symbols["INIT"]
    assert (init.kind, lines[init.range.end.line]) == ("block", "END INIT")
    assert symbols["INTERRUPTS stroke"].range.start.line == lines.index("INTERRUPTS stroke")
    assert lines[symbols["TRIGGERS"].range.end.line] == "END TRIGGERS"
    assert {"COMP_PLUS", "ON_LP", "stroke", "at_2000", "at_6000"} <= set(symbols)
    folded = {(f.first, f.last) for f in outline.folding_ranges(analysis)}
    assert (lines.index("INIT"), lines.index("END INIT")) in folded
    assert (lines.index("TRIGGERS"), lines.index("END TRIGGERS")) in folded


def test_workspace_symbols_filter_by_any_case(tmp_path: Path) -> None:
    analysis = check(tmp_path, LOOPS)
    assert [s.name for s, _ in outline.workspace_symbols([analysis], "LOOP")] == ["loops"]
    assert outline.workspace_symbols([analysis, analysis], "unclosed")[0][1] == analysis.path


def test_semantic_tokens_classify_words_as_hover_does(tmp_path: Path) -> None:
    analysis = check(tmp_path, "CONST N = 2  # two\nMP 1\n    SET_V X, N\nEND MP\n")
    data = outline.semantic_tokens(analysis)
    decoded = []
    line = start = 0
    for index in range(0, len(data), 5):
        line += data[index]
        start = data[index + 1] + (start if data[index] == 0 else 0)
        decoded.append((line, start, data[index + 2], outline.TOKEN_TYPES[data[index + 3]],
                        data[index + 4]))
    readonly = 1 << outline.TOKEN_MODIFIERS.index("readonly")
    declaration = 1 << outline.TOKEN_MODIFIERS.index("declaration")
    library = 1 << outline.TOKEN_MODIFIERS.index("defaultLibrary")
    assert decoded[:5] == [(0, 0, 5, "keyword", 0), (0, 6, 1, "variable",
                                                     readonly | declaration),
                           (0, 8, 1, "operator", 0), (0, 10, 1, "number", 0),
                           (0, 13, 5, "comment", 0)]
    assert (2, 4, 5, "function", library) in decoded
    assert (2, 10, 1, "enumMember", library) in decoded
    assert (2, 13, 1, "variable", readonly) in decoded


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 9), max_size=40), st.lists(st.integers(0, 9), max_size=40))
def test_token_delta_turns_the_old_data_into_the_new(old: list[int], new: list[int]) -> None:
    old, new = old[:len(old) // 5 * 5], new[:len(new) // 5 * 5]
    start, deleted, inserted = outline.token_delta(old, new)
    assert start % 5 == 0 and deleted % 5 == 0 and len(inserted) % 5 == 0
    assert old[:start] + inserted + old[start + deleted:] == new


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 800), st.integers(0, 12), st.integers(0, 12))
def test_token_delta_of_a_long_document_edited_in_one_place(seed: int, tokens: int, cut: int,
                                                            added: int) -> None:
    """Thousands of tokens, a few replaced somewhere (also at either end, or none): the
    delta still gives the new data, and covers no more than the tokens that differ."""
    rng = random.Random(seed)
    old = [rng.randrange(4) for _ in range(tokens * 5)]
    at = rng.randrange(tokens + 1) * 5
    new = old[:at] + [rng.randrange(4) for _ in range(added * 5)] + old[at + cut * 5:]
    start, deleted, inserted = outline.token_delta(old, new)
    assert start % 5 == 0 and deleted % 5 == 0 and len(inserted) % 5 == 0
    assert old[:start] + inserted + old[start + deleted:] == new
    assert start >= at
    assert len(inserted) <= 5 * added


def test_signature_help_inside_a_call_and_its_arguments(tmp_path: Path) -> None:
    analysis = check(tmp_path, "MP 1\n    VAR1 = GET_LP(X)\n    SET_V X, 1\nEND MP\n")
    query = outline.signature_help(analysis, Pos(1, 18))
    assert query is not None and query.label == "GET_LP(axis)" and query.active == 0
    (offsets, doc), = query.parameters
    assert query.label[offsets[0]:offsets[1]] == "axis" and "one axis" in doc
    second = outline.signature_help(analysis, Pos(2, 13))
    assert second is not None and second.active == 1
    assert outline.signature_help(analysis, Pos(0, 2)) is None  # a program header


def test_a_line_of_thousands_of_words_is_read_in_one_pass(tmp_path: Path) -> None:
    """Past WORDS_IN_PLACE words a word is read alone: still classified, and a hostile line
    costs linear time instead of a re-read of the line per word."""
    from mplang.tools.lsp import editing
    from mplang.tools.lsp.tokens import WORDS_IN_PLACE, line_words

    expression = "+".join(["A"] * 5000)
    words = line_words(f"    VAR1 = {expression}")
    assert len(words) == 5001
    assert words[WORDS_IN_PLACE - 1][1].position > 0 and words[WORDS_IN_PLACE][1].position == 0
    analysis = check(tmp_path, f"CONST A = 1\nMP 1\n    VAR1 = {expression}\nEND MP\n")
    data = outline.semantic_tokens(analysis)
    constants = [data[i + 3] for i in range(0, len(data), 5)
                 if data[i + 4] & (1 << outline.TOKEN_MODIFIERS.index("readonly"))]
    assert len(constants) == 5001  # the definition and every use
    assert len(editing.references(analysis, Pos(0, 6))) == 5001


EDITED_LINES = ["CONST SPEED = 5", "ALIAS speed = VAR7", "VAR pace", "MP 3 speed", "MP 4",
                "END MP", "    SET_V X, SPEED", "    pace = speed + 1", "    CALL speed",
                "    GOTO top", "LABEL top", "    MP 5 (", "    IF SPEED > 1", "    END IF",
                "    NOPE X", "# speed 😀", "    SET_V Y, 'é' + pace"]


def _tokens_as_fresh(analysis: Analysis) -> None:
    """The tokens of `analysis` made from what the last passes kept equal those made with
    nothing kept."""
    kept = outline.semantic_tokens(analysis)
    outline._classified_lines.clear()
    outline._passes.clear()
    assert kept == outline.semantic_tokens(analysis)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.lists(st.sampled_from(EDITED_LINES), max_size=10), min_size=2, max_size=4))
@example([["    MP 5 ("], ["MP 4", "    MP 5 ("]])  # a bad header, alone, then after one
def test_tokens_kept_by_line_equal_tokens_classified_afresh(texts: list[list[str]]) -> None:
    """A sequence of edits that define and drop names (a CONST, an ALIAS, a VAR, a program
    named like them) and move program headers: the tokens computed with the lines kept from
    the texts before equal those of the same text with nothing kept."""
    path = Path("edited.mp")
    for lines in texts:
        analysis = analyse(path, "\n".join(lines) + "\n")
        _tokens_as_fresh(analysis)


SPLICED_LINES = [*EDITED_LINES, "", "    ", "END MP"]
"""With lines of no token: the first token after an edit then counts its line from further
up."""


def _edit(lines: list[str], kind: int, at: int, text: str) -> None:
    """Replace (kind 0), insert (1) or drop (2) a line, at `at` or the last place there is."""
    at = min(at, len(lines) - (kind != 1))
    if kind == 0 and lines:
        lines[at] = text
    elif kind == 1:
        lines.insert(at, text)
    elif lines:
        del lines[at]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(SPLICED_LINES), min_size=1, max_size=14),
       st.lists(st.tuples(st.integers(0, 2), st.integers(0, 20),
                          st.sampled_from(SPLICED_LINES)), min_size=1, max_size=6))
@example(["MP 4", "    SET_V X, SPEED", "END MP", "    MP 5 (", "CONST SPEED = 5"],
         [(2, 2, "")])  # the END dropped: the refused header after it is in a block then
@example(["LABEL top", "    GOTO top", "# speed 😀", "    GOTO top"], [(1, 0, "VAR pace")])
def test_tokens_after_edits_equal_a_fresh_documents(first: list[str],
                                                    edits: list[tuple[int, int, str]]
                                                    ) -> None:
    """Edits of one document (a line replaced, inserted or dropped), its tokens made from
    the last edit's each time (the lines before and after the edit taken as they were):
    each time equal to the tokens of the same text with nothing kept."""
    path = Path("spliced.mp")
    lines = list(first)
    outline._passes.clear()
    outline.semantic_tokens(analyse(path, "\n".join(lines) + "\n"))
    for kind, at, text in edits:
        _edit(lines, kind, at, text)
        analysis = analyse(path, "\n".join(lines) + "\n")
        _tokens_as_fresh(analysis)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(SPLICED_LINES), min_size=1, max_size=14),
       st.lists(st.tuples(st.integers(0, 2), st.integers(0, 20),
                          st.sampled_from(SPLICED_LINES), st.booleans()),
                min_size=1, max_size=6))
@example(["    NOPE X", "    GOTO top", "VAR pace", "    SET_V X, pace"],
         [(0, 1, "", False), (0, 3, "    NOPE X", True)])  # the tokens of the first edit's
# text were never asked for: the second edit's lines shared with it are not the last pass's
def test_tokens_after_checks_kept_between_equal_a_fresh_documents(
        first: list[str], edits: list[tuple[int, int, str, bool]]) -> None:
    """Edits of one document checked as the server checks them (each analysis made with the
    last one, which finds the lines the edit left alone), its tokens asked for after some of
    them only: each time equal to the tokens of the same text with nothing kept. Lines
    found shared with an analysis whose tokens were never made are not taken as shared with
    the last tokens made."""
    path = Path("kept.mp")
    lines = list(first)
    outline._passes.clear()
    analysis = analyse(path, "\n".join(lines) + "\n")
    outline.semantic_tokens(analysis)
    for kind, at, text, asked in edits:
        _edit(lines, kind, at, text)
        analysis = analyse(path, "\n".join(lines) + "\n", previous=analysis)
        if asked:
            _tokens_as_fresh(analysis)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(SPLICED_LINES), min_size=1, max_size=14),
       st.lists(st.tuples(st.integers(0, 2), st.integers(0, 20),
                          st.sampled_from(SPLICED_LINES)), min_size=1, max_size=6))
@example(["    SET_V X, pace", "    NOPE X", "    SET_V X, pace"], [(0, 1, "    GOTO top")])
def test_a_delta_from_the_last_tokens_is_the_least_edit(first: list[str],
                                                        edits: list[tuple[int, int, str]]
                                                        ) -> None:
    """The delta from the tokens of the last pass to those spliced from them (the ends the
    splice took as they were not compared) turns the old into the new and is the delta of
    two unrelated lists of the same numbers: the least edit."""
    path = Path("delta.mp")
    lines = list(first)
    outline._passes.clear()
    last = outline.semantic_tokens(analyse(path, "\n".join(lines) + "\n"))
    for kind, at, text in edits:
        _edit(lines, kind, at, text)
        data = outline.semantic_tokens(analyse(path, "\n".join(lines) + "\n"))
        start, deleted, inserted = outline.token_delta(last, data)
        assert last[:start] + inserted + last[start + deleted:] == data
        assert (start, deleted, inserted) == outline.token_delta(list(last), list(data))
        last = data


def test_a_delta_scans_past_the_kept_end_when_tokens_were_added() -> None:
    """The kept end of a spliced pass bounds the scan for the common start only when old and
    new are as long: a token added before that end, equal to the one after it, is still an
    edit (the lists are not equal for having equal starts up to the kept end)."""
    token, other = [1, 0, 3, 8, 0], [0, 4, 2, 2, 0]
    old = [*other, *token, *token]
    for new, same in (([*other, *token, *token, *token], (5, 5)),
                      ([*other, *token, *other], (5, 0)), ([*other, *token, *token], (5, 5))):
        outline._passes.clear()
        outline._passes[Path("kept.mp")] = outline._Pass([], (), [], [], new, [], old, same)
        start, deleted, inserted = outline.token_delta(old, new)
        assert old[:start] + inserted + old[start + deleted:] == new
        outline._passes.clear()
        assert (start, deleted, inserted) == outline.token_delta(list(old), list(new))


def test_tokens_of_an_ascii_text_are_not_converted(tmp_path: Path) -> None:
    """An ASCII document's tokens are the very list the pass keeps, whatever the client's
    encoding (the text tells it at once); a non-ASCII one's are a converted copy."""
    from mplang.tools.lsp.handlers import in_client_units

    for text, ascii_only in (("MP 1\n    VAR1 = 1\nEND MP\n", True),
                             ("MP 1\n    VAR_CALCULATE VAR2, '\u00e9', VAR3, VAR4\nEND MP\n",
                              False)):
        analysis = analyse(tmp_path / "a.mp", text)
        data = outline.semantic_tokens(analysis)
        for encoding in ("utf-8", "utf-16"):
            converted = in_client_units(data, analysis.lines, encoding, analysis.text)
            assert converted == in_client_units(data, analysis.lines, encoding)
            assert (converted is data) is ascii_only
            assert (converted == data) is (ascii_only or encoding == "utf-16")
