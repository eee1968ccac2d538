"""Front end: statement forms, syntax errors with positions, recovery, and robustness."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from outcomes import assert_diagnostics

from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.parser import parse_text
from mplang.m8194h.compiler import compile_source


def parse(text: str) -> tuple[list[ast.Statement], DiagnosticSink]:
    sink = DiagnosticSink()
    return parse_text(text, "t.mp", sink), sink


def test_every_statement_form_parses() -> None:
    text = """CONST A = 2 * (3 + 4)   # comment
ALIAS count = VAR1          // comment
INCLUDE "lib.mp"
MP 21 square
isr 3 on_compare
end mp
FOR count
NEXT
EXIT FOR
EXIT
IF VAR1 <= -5 THEN
ELSE
END IF
LABEL top
GOTO 2
CALL MP21
CALL helper
TERMINATE
VAR2 = GET_LP(X)
FIXED_MOVE X, -1000
FIXED_MOVE(AXIS_X, 0x10)
NEXT_STEP X
"""
    statements, sink = parse(text)
    assert not sink.items
    kinds = [type(s).__name__ for s in statements]
    assert kinds == ["Const", "Alias", "Include", "ProgramHeader", "ProgramHeader", "End",
                     "ForStmt", "Next", "ExitFor", "Exit", "IfStmt", "Else", "End",
                     "LabelStmt", "Goto", "CallStmt", "CallStmt", "Terminate", "Assign",
                     "Command", "Command", "Command"]
    paren = statements[20]
    assert isinstance(paren, ast.Command) and len(paren.args) == 2
    assert isinstance(paren.args[1], ast.Num) and paren.args[1].value == 16


def test_keywords_are_case_insensitive_and_prefixes_stay_names() -> None:
    statements, sink = parse("Mp 3\nfor_each X\nMP21_CALL\nEnD Mp\n")
    assert not sink.items
    assert isinstance(statements[0], ast.ProgramHeader)
    assert isinstance(statements[1], ast.Command) and statements[1].name == "for_each"
    assert isinstance(statements[2], ast.Command)


def test_every_bad_line_is_reported_with_its_column() -> None:
    text = "MP 1\n  FIXED_MOVE X,, 3\n  VAR1 = \n  IF VAR1 = 3\n  $\nEND MP\n"
    _statements, sink = parse(text)
    where = sorted((d.span.line, d.span.col) for d in sink.items)
    assert where == [(2, 16), (3, 9), (4, 11), (5, 3)]
    assert all(d.code == "E101" for d in sink.items)
    assert "comparison" in next(d.message for d in sink.items if d.span.line == 4)
    assert "'=='" in next(d.hint for d in sink.items if d.span.line == 4)


def test_a_broken_block_line_does_not_cascade() -> None:
    result = compile_source("MP 1\n  IF VAR1 = 3\n  END IF\nEND MP\n")
    assert [d.code for d in result.diagnostics] == ["E101"]


def test_spans_point_at_arguments() -> None:
    result = compile_source("MP 1\n  FIXED_MOVE X,   Q\nEND MP\n")
    (diag,) = result.diagnostics
    assert (diag.code, diag.span.line, diag.span.col) == ("E202", 2, 19)


SNIPPETS = ["MP ", "END MP", "FOR ", "NEXT", "IF ", "END IF", "ELSE", "LABEL ", "GOTO ",
            "CALL ", "VAR1", "FIXED_MOVE X, 1", "\n", 'INCLUDE "x.mp"', "CONST A = ", "ISR 3"]
source_alphabet = st.sampled_from([*"MPISRENDFOXYZUVAR0123456789 ,=<>!()+-*/&|#\"'\n\t_.;$",
                                   *SNIPPETS])


@settings(max_examples=300, deadline=None)
@given(st.lists(source_alphabet, max_size=60).map("".join))
def test_arbitrary_text_only_gives_diagnostics(text: str) -> None:
    result = compile_source(text)
    for diag in result.diagnostics:
        assert diag.span.line >= 1 and diag.code[0] in "EW"


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=200))
def test_arbitrary_unicode_only_gives_diagnostics(text: str) -> None:
    assert_diagnostics(compile_source(text))


def test_leading_zeros_are_decimal_not_a_crash() -> None:
    """Numbers are decimal or 0x hex; a leading zero changes nothing (`010` is ten) and
    used to raise inside the parser."""
    result = compile_source("MP 1 a\n    VAR1 = 010\nEND MP\n")
    assert result.ok
    assert result.programs[0].lines[0].frame[-1] == 10
