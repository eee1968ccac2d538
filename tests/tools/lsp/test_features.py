"""Hover, completion, go to definition and the budget lenses, as an editor asks for them,
on documents with errors."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.tools.lsp import features
from mplang.tools.lsp.analysis import Analysis, analyse
from mplang.tools.lsp.positions import Pos, line_range

MAIN = """INCLUDE "common.mp"
ALIAS count = VAR1

MP 21 main
    SET_V XY, SPEED
    FIXD_MOVE X, 1000
    LABEL top
    count = count + 1
    MIX_2D_CONTINUE 0, LINE_2D, 0, 0, 100, 100
    IF VAR3 = 2
    END IF
    GOTO top
    CALL helper
    CALL MP40
END MP

MP helper
    INTFACTOR_ENABLE X, 1, on_home
    VAR2 = GET_LP(X)
END MP

ISR 2 on_home
    SET_LP X, 0
END ISR
"""
COMMON = "CONST SPEED = 2000 * 2\n"


@pytest.fixture(scope="module")
def analysis(tmp_path_factory: pytest.TempPathFactory) -> Analysis:
    project = tmp_path_factory.mktemp("features")
    (project / ".git").mkdir()
    (project / "common.mp").write_text(COMMON)
    (project / "lib").mkdir()
    (project / "lib" / "axes.mp").write_text("")
    return analyse(project / "main.mp", MAIN)


def at(word: str, nth: int = 0, offset: int = 1) -> Pos:
    """A position inside the nth occurrence of `word` in MAIN."""
    hits = [(n, line.index(word)) for n, line in enumerate(MAIN.split("\n")) if word in line]
    line, column = hits[nth]
    return Pos(line, column + offset)


def hover_text(analysis: Analysis, pos: Pos) -> str:
    found = features.hover(analysis, pos)
    assert found is not None
    return found.markdown


def labels(entries: list[features.CompletionEntry]) -> list[str]:
    return [e.label for e in entries]


# ----------------------------------------------------------------------------------- hover


def test_hover_on_a_command_shows_its_catalogue_entry(analysis: Analysis) -> None:
    found = features.hover(analysis, at("MIX_2D_CONTINUE"))
    assert found is not None and found.range == line_range(8, 4, 19)
    text = found.markdown
    assert "**MIX_2D_CONTINUE** (RSM_MACRO_MIX_2D_CONTINUE / ETM_MACRO_MIX_2D_CONTINUE)" in text
    assert "| `nType` | BYTE | one of 1 (LINE_2D), 2 (ARC_CW)" in text
    assert "- Scope: MP\n" in text
    assert "- Line cost: 2 macro lines (x2)" in text
    assert ("- Manual: section 7.4.9 of the RS-M8194H API manual v3.1 (Table 1 line 604, appendix "
            "line 11755, prototype line 8746, example line 8788)") in text


def test_hover_on_a_value_returning_read_and_its_axis(analysis: Analysis) -> None:
    text = hover_text(analysis, at("GET_LP"))
    assert "`VARn = GET_LP(axis)`" in text and "- Scope: MP, ISR" in text
    assert "Returns a value" in text
    assert hover_text(analysis, at("XY")) == "**XY**: axis code 0x3 (X + Y)"


def test_hover_still_works_next_to_a_syntax_error(analysis: Analysis) -> None:
    assert "IF a CMP b" in hover_text(analysis, at("IF VAR3"))
    assert hover_text(analysis, at("VAR3")).startswith("**VAR3**: device variable, sent as "
                                                       "0x7fff0003")


def test_hover_on_names_says_what_and_where(analysis: Analysis) -> None:
    assert hover_text(analysis, at("SPEED")).startswith("**CONST SPEED** = 4,000")
    assert "common.mp:1" in hover_text(analysis, at("SPEED"))
    assert hover_text(analysis, at("count", 1)).startswith("**ALIAS count** = VAR1")
    assert "ALIAS: count" in hover_text(analysis, at("VAR1"))
    assert hover_text(analysis, at("top", 1)).startswith("**LABEL top** of MP 21 main")
    helper = hover_text(analysis, at("helper"))
    assert helper.startswith("**MP helper**\n\nMP1: 4/8 lines (auto-placed)")
    assert "main.mp:17" in helper
    assert "on_home" in hover_text(analysis, at("on_home"))
    assert "no program of this build" in hover_text(analysis, at("MP40"))
    assert "= 1 (0x1): a value of `nType` of MIX_2D_CONTINUE" in \
        hover_text(analysis, at("LINE_2D"))


def test_hover_on_keywords_shows_what_they_lower_to(analysis: Analysis) -> None:
    assert "**MP_CLOSE**" in hover_text(analysis, at("END MP"))
    assert "**END_IF**" in hover_text(analysis, at("END IF", 0, 5))
    assert "**END_IF**" in hover_text(analysis, at("END IF"))
    assert "**MP_CALL**" in hover_text(analysis, at("CALL"))


def test_no_hover_on_numbers_comments_or_past_the_end(analysis: Analysis) -> None:
    assert features.hover(analysis, at("1000")) is None
    assert features.hover(analysis, Pos(99, 0)) is None
    assert features.hover(analysis, Pos(2, 0)) is None


def test_hover_on_an_include_names_the_file(analysis: Analysis) -> None:
    text = hover_text(analysis, at('"common.mp"'))
    assert "common.mp" in text and "part of this build" in text


# ------------------------------------------------------------------------------ definition


def test_definition_of_constants_aliases_labels_and_programs(analysis: Analysis) -> None:
    (speed,) = features.definition(analysis, at("SPEED"))
    assert speed.path.name == "common.mp" and speed.range == line_range(0, 6, 11)
    (alias,) = features.definition(analysis, at("count + 1"))
    assert alias.range == line_range(1, 6, 11)
    (label,) = features.definition(analysis, at("top", 1))
    assert label.range == line_range(6, 10, 13)
    (called,) = features.definition(analysis, at("helper"))
    assert called.range == line_range(16, 3, 9)
    (isr,) = features.definition(analysis, at("on_home"))
    assert isr.range == line_range(21, 6, 13)
    (included,) = features.definition(analysis, at('"common.mp"'))
    assert included.path == analysis.path.parent / "common.mp"


def test_no_definition_for_commands_or_unknown_slots(analysis: Analysis) -> None:
    assert features.definition(analysis, at("SET_V")) == []
    assert features.definition(analysis, at("MP40")) == []


# ------------------------------------------------------------------------------ completion


def test_statement_start_offers_keywords_commands_and_variables(analysis: Analysis) -> None:
    entries = features.completion(analysis, Pos(4, 4))
    found = {e.label: e for e in entries}
    assert {"FOR", "END MP", "GOTO", "count", "VAR1"} <= set(found)
    fixed = found["FIXED_MOVE"]
    assert fixed.insert_text == "FIXED_MOVE ${1:axis}, ${2:data}" and fixed.snippet
    assert "GET_LP" in found and "MP_CLOSE" not in found


def test_statement_start_in_an_isr_offers_only_what_an_isr_takes(analysis: Analysis) -> None:
    found = set(labels(features.completion(analysis, Pos(22, 4))))
    assert {"SET_LP", "IF", "END ISR"} <= found
    assert not found & {"FOR", "GOTO", "CALL", "STOP_WAIT", "SET_HV", "END MP"}


def test_top_level_offers_declarations_and_program_snippets() -> None:
    analysis = analyse(Path("empty.mp"), "\n")
    entries = features.completion(analysis, Pos(0, 0))
    assert labels(entries) == ["CONST", "ALIAS", "VAR", "INCLUDE", "MP", "ISR"]
    assert entries[4].insert_text == "MP ${1:name}\n\t$0\nEND MP"


def test_goto_offers_the_labels_of_its_program(analysis: Analysis) -> None:
    assert labels(features.completion(analysis, at("top", 1, 0))) == ["top"]


def test_call_offers_programs_by_name_and_slot(analysis: Analysis) -> None:
    found = labels(features.completion(analysis, at("helper", 0, 0)))
    assert found == ["main", "MP21", "helper", "MP1"]


def test_arguments_offer_what_the_parameter_takes(analysis: Analysis) -> None:
    axes = labels(features.completion(analysis, at("XY", 0, 0)))
    assert axes[:4] == ["X", "Y", "Z", "U"] and "XYZU" in axes
    single = labels(features.completion(analysis, at("X, 1, on_home", 0, 0)))
    assert single == ["X", "Y", "Z", "U"]
    shapes = labels(features.completion(analysis, at("LINE_2D", 0, 0)))
    assert shapes == ["LINE_2D", "ARC_CW", "ARC_CCW", "CIRCLE_CW", "CIRCLE_CCW"]
    isrs = labels(features.completion(analysis, at("on_home", 0, 0)))
    assert isrs == ["on_home", "ISR2"]
    values = labels(features.completion(analysis, at("SPEED", 0, 0)))
    assert values[:3] == ["SPEED", "count", "VAR1"]


def test_values_after_an_equals_sign_include_the_reads(analysis: Analysis) -> None:
    entries = {e.label: e for e in features.completion(analysis, at("count + 1", 0, 0))}
    assert {"count", "SPEED", "GET_LP", "GET_ERROR"} <= set(entries)
    assert entries["GET_LP"].insert_text == "GET_LP(${1:axis})"
    assert entries["GET_ERROR"].insert_text == "GET_ERROR"


def test_after_end_and_exit(analysis: Analysis) -> None:
    assert labels(features.completion(analysis, at("END IF", 0, 4))) == ["MP", "ISR", "IF", "FOR"]


def test_no_completion_in_comments_and_headers() -> None:
    analysis = analyse(Path("c.mp"), "MP 1 x # SET\nEND MP\n")
    assert features.completion(analysis, Pos(0, 12)) == []
    assert features.completion(analysis, Pos(0, 5)) == []


def test_include_path_completion_lists_mp_files_nearby(analysis: Analysis) -> None:
    found = labels(features.completion(analysis, Pos(0, 10)))
    assert found == ["common.mp", "lib/axes.mp"]


# --------------------------------------------------------------------------------- budgets


def test_every_program_header_gets_its_budget(analysis: Analysis) -> None:
    budgets = features.program_budgets(analysis)
    assert [(b.range.start.line, b.title) for b in budgets] == [
        (3, "MP21: 11/8 lines, over budget"), (16, "MP1: 4/8 lines (auto-placed)"),
        (21, "ISR2: 2/8 lines")]
    assert budgets[0].range == line_range(3, 0, 10)


def test_axis_names_follow_the_manuals_table_order(analysis: Analysis) -> None:
    assert features.axis_names(analysis) == ["X", "Y", "Z", "U", "XY", "XZ", "XU", "YZ", "YU",
                                             "ZU", "XYZ", "XYU", "XZU", "YZU", "XYZU"]


# ------------------------------------------------------------------------ any text at all

FRAGMENTS = ["MP 1 a", "ISR 2", "END MP", "END ISR", "FOR 3", "NEXT", "IF VAR1 > 2", "ELSE",
             "END IF", "LABEL a", "GOTO a", "CALL a", "CALL MP9", "FIXED_MOVE X, 1",
             "SET_V XY, K", "VAR2 = GET_LP(", "VAR3 = (1 + ", 'INCLUDE "', 'INCLUDE "x.mp"',
             "CONST K = 2 *", "ALIAS b = VAR", "VAR v @ VAR3", "EXIT FOR", "END",
             "MIX_2D_CONTINUE 0, LINE_2D,", "# comment", "'😀'", ",", "(", "@"]
LINES = st.lists(st.one_of(st.sampled_from(FRAGMENTS),
                           st.text(st.characters(exclude_categories=("Cs",)), max_size=12)),
                 max_size=12)


@settings(max_examples=40, deadline=None)
@given(lines=LINES, spots=st.lists(st.tuples(st.integers(-1, 14), st.integers(0, 40)),
                                   min_size=1, max_size=6))
def test_no_text_and_no_position_makes_a_feature_fail(
        tmp_path_factory: pytest.TempPathFactory, lines: list[str],
        spots: list[tuple[int, int]]) -> None:
    folder = tmp_path_factory.getbasetemp() / "anytext"
    folder.mkdir(exist_ok=True)
    analysis = analyse(folder / "any.mp", "\n".join(lines))
    features.program_budgets(analysis)
    for line, character in spots:
        pos = Pos(line, character)
        found = features.hover(analysis, pos)
        if found is not None:
            assert found.range.start.line == line and found.markdown
        features.completion(analysis, pos)
        features.definition(analysis, pos)
