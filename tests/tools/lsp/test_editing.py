"""Formatting edits, quick fixes, references and rename over an `Analysis`, without pygls
(`mplang.tools.lsp.editing`). The server glue is tested over stdio in test_editing_server.py."""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.tools.fmt import FormatOptions, format_source
from mplang.tools.lsp import editing
from mplang.tools.lsp.analysis import analyse
from mplang.tools.lsp.editing import RenameRefused, TextEdit
from mplang.tools.lsp.positions import Pos, Range

SAMPLES = sorted(Path(__file__).resolve().parents[3].joinpath("samples").rglob("*.mp"))


def apply(text: str, edits: list[TextEdit]) -> str:
    lines = editing._lines_with_breaks(text)
    starts = [0]
    for line in lines:
        starts.append(starts[-1] + len(line))

    def offset(pos: Pos) -> int:
        return starts[pos.line] + pos.character if pos.line < len(lines) else len(text)

    for edit in sorted(edits, key=lambda e: e.range.start, reverse=True):
        text = text[:offset(edit.range.start)] + edit.text + text[offset(edit.range.end):]
    return text


@pytest.mark.parametrize("sample", SAMPLES, ids=lambda p: p.name)
def test_format_edits_give_exactly_what_mpc_fmt_writes(sample: Path) -> None:
    text = sample.read_text()
    for variant in (text, text.rstrip("\n"), text.replace("\n", "\r\n"), "\n\n" + text):
        for options in (FormatOptions(), FormatOptions(indent=2, keyword_case="lower")):
            edits = editing.format_edits(variant, options)
            assert apply(variant, edits) == format_source(variant, options)


def test_a_formatted_text_needs_no_edit_and_a_broken_one_gets_none() -> None:
    clean = format_source("MP 1\nSET_V X, 1\nEND MP\n")
    assert editing.format_edits(clean, FormatOptions()) == []
    assert editing.format_edits("MP 1\n  FOR 3 (\nEND MP\n", FormatOptions()) == []
    # A lone carriage return: editors count a line break where the compiler sees none.
    assert editing.format_edits("MP 1\r  SET_V X, 1\nEND MP\n", FormatOptions()) == []


def test_range_formatting_keeps_to_the_lines_asked_for() -> None:
    text = "MP 1\n  SET_V X,1\n        SET_V Y,  2\nEND MP\n"
    edits = editing.format_edits(text, FormatOptions(), (2, 2))
    assert apply(text, edits) == "MP 1\n  SET_V X,1\n    SET_V Y, 2\nEND MP\n"
    assert editing.format_edits(text, FormatOptions(), (0, 0)) == []


def check(tmp_path: Path, text: str, name: str = "main.mp") -> editing.Analysis:
    path = tmp_path / name
    path.write_text(text)
    return analyse(path, text)


WARNED = "MP 1\n    VAR1 = VAR1 + 1{comment}\nEND MP\n"


@pytest.mark.parametrize(("comment", "expected"), [
    ("", "    VAR1 = VAR1 + 1  # mpc: ignore[W103]"),
    ("  # counter", "    VAR1 = VAR1 + 1  # counter  mpc: ignore[W103]"),
    ("  # mpc: ignore[W101]", "    VAR1 = VAR1 + 1  # mpc: ignore[W101, W103]"),
])
def test_ignore_action_writes_or_extends_the_comment(tmp_path: Path, comment: str,
                                                     expected: str) -> None:
    analysis = check(tmp_path, WARNED.format(comment=comment))
    (fix,) = [f for f in editing.quick_fixes(analysis, Range(Pos(1, 0), Pos(1, 0)))
              if f.title.startswith("Ignore")]
    fixed = apply(WARNED.format(comment=comment), [fix.edit])
    assert fixed.split("\n")[1] == expected
    assert [d.code for d in analyse(tmp_path / "main.mp", fixed).diagnostics] == []


def test_no_ignore_action_for_errors_or_a_line_already_silenced(tmp_path: Path) -> None:
    analysis = check(tmp_path, WARNED.format(comment="  # mpc: ignore"))
    assert editing.quick_fixes(analysis, Range(Pos(0, 0), Pos(3, 0))) == []
    errors = check(tmp_path, "MP 1\n    SET_V Q, 1\nEND MP\n")
    assert [f.title for f in editing.quick_fixes(errors, Range(Pos(1, 0), Pos(1, 20)))] == []


def test_no_fix_for_a_problem_of_an_included_file(tmp_path: Path) -> None:
    (tmp_path / "lib.mp").write_text("MP 2\n    FIXD_MOVE X, 1\nEND MP\n")
    analysis = check(tmp_path, 'INCLUDE "lib.mp"\n')
    assert [d.code for d in analysis.diagnostics] == ["E201"]
    assert editing.quick_fixes(analysis, Range(Pos(0, 0), Pos(0, 20))) == []


PROGRAM = """CONST GAP = 10
ALIAS parts = VAR3
VAR done
MP 1 feed
    LABEL again
    parts = parts + GAP
    done = GAP
    GOTO again
END MP
MP 2 other
    LABEL again
    GOTO again
    CALL feed
END MP
"""


def test_references_of_names_and_labels(tmp_path: Path) -> None:
    analysis = check(tmp_path, PROGRAM)
    gap = editing.references(analysis, Pos(5, 22))
    assert [(r.range.start.line, r.range.start.character) for r in gap] == [
        (0, 6), (5, 20), (6, 11)]
    # A label belongs to its program: the other program's `again` is not a reference.
    again = editing.references(analysis, Pos(7, 10))
    assert [r.range.start.line for r in again] == [4, 7]
    done = editing.references(analysis, Pos(2, 5), include_declaration=False)
    assert [r.range.start.line for r in done] == [6]
    parts = editing.references(analysis, Pos(5, 14))
    assert [(r.range.start.line, r.range.start.character) for r in parts] == [
        (1, 6), (5, 4), (5, 12)]
    assert editing.references(analysis, Pos(11, 5)) == []  # GOTO, a keyword


def test_rename_checks_the_new_name(tmp_path: Path) -> None:
    analysis = check(tmp_path, PROGRAM)
    edits = editing.rename(analysis, Pos(3, 6), "feeder")
    assert sorted(e.range.start.line for e in edits[analysis.path]) == [3, 12]
    for bad, why in (("9x", "is not a name"), ("SET_V", "keyword or a command"),
                     ("parts", "already names an ALIAS"), ("other", "the program MP 2")):
        with pytest.raises(RenameRefused, match=why):
            editing.rename(analysis, Pos(3, 6), bad)
    assert editing.rename_range(analysis, Pos(5, 8)) == Range(Pos(5, 4), Pos(5, 9))  # parts
    assert editing.rename_range(analysis, Pos(11, 2)) is None  # GOTO
    two = check(tmp_path, PROGRAM.replace("    LABEL again\n    parts",
                                          "    LABEL again\n    LABEL later\n    parts", 1),
                "two.mp")
    with pytest.raises(RenameRefused, match="a label of MP 1 feed"):
        editing.rename(two, Pos(4, 11), "later")
    assert editing.rename(two, Pos(4, 11), "again") != {}  # its own name: no clash


def test_every_did_you_mean_hint_is_a_fix_in_the_defined_spelling(tmp_path: Path) -> None:
    text = ("CONST SPEED = 10\nMP 1 helper\n    SET_V X, SPED\nEND MP\nMP 2 main\n"
            "    CALL helpr\n    FIXD_MOVE X, 1\nEND MP\nINTERRUPTS mainn\n"
            "    ON X P>=C+ CALL ISR 1\nEND INTERRUPTS\nISR 1\n    SET_V X, 1\nEND ISR\n")
    analysis = check(tmp_path, text)
    fixes = [f for f in editing.quick_fixes(analysis, Range(Pos(0, 0), Pos(20, 0)))
             if f.preferred]
    assert [f.title for f in fixes] == [
        "Replace 'SPED' with 'SPEED'", "Replace 'helpr' with 'helper'",
        "Replace 'FIXD_MOVE' with 'FIXED_MOVE'", "Replace 'mainn' with 'main'"]
    fixed = apply(text, [f.edit for f in fixes])
    assert [d.code for d in analyse(tmp_path / "main.mp", fixed).diagnostics
            if d.severity == "error"] == []
