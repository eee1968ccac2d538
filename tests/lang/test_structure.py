"""Block matching's raw spellings (mplang.lang.structure.normalise): each raw block command,
with or without its RSM_MACRO_ / ETM_MACRO_ prefix and in any case, is the statement its
keyword makes; any other command is left as it is."""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.parser import parse_text
from mplang.lang.sources import SourceFile, SourceSet
from mplang.lang.structure import build_unit, normalise

RAW = [("END_IF", ast.End), ("ELSE", ast.Else), ("EXIT_FOR", ast.ExitFor),
       ("EXIT_MACRO", ast.Exit), ("MP_TERMINATE", ast.Terminate), ("NEXT", ast.Next),
       ("FOR 3", ast.ForStmt), ("IF VAR1, 0x3D3D, 2", ast.IfStmt),
       ("MP_CALL 7", ast.CallStmt), ("GOTO 1", ast.Goto), ("LABEL 1", ast.LabelStmt)]


def _command(text: str) -> ast.Statement:
    sink = DiagnosticSink()
    statements = parse_text(f"MP 1\n  {text}\nEND MP\n", "a.mp", sink)
    assert not sink.items, sink.items
    return statements[1]


@pytest.mark.parametrize(("text", "made"), RAW)
@pytest.mark.parametrize("prefix", ["", "RSM_MACRO_", "etm_macro_"])
def test_a_raw_block_command_is_its_keyword_statement(text: str, made: type, prefix: str
                                                      ) -> None:
    if not prefix and made is ast.IfStmt:
        text = "IF VAR1 > 2"  # unprefixed, IF is the keyword: its raw form is refused
    statement = _command(prefix + text)
    if not isinstance(statement, ast.Command):  # the parser took the keyword itself
        assert isinstance(statement, made)
        return
    assert isinstance(normalise(statement), made)


@pytest.mark.parametrize("text", ["SET_A Y, 5000", "RSM_MACRO_SET_V X, 25", "IF_X 1",
                                  "NEXT_POS X, 3"])
def test_any_other_command_is_left_as_it_is(text: str) -> None:
    statement = _command(text)
    assert isinstance(statement, ast.Command)
    assert normalise(statement) is statement


def test_block_spellings_are_never_taken_for_plain_names_learnt_before() -> None:
    """Block matching skips `normalise` for the command names it learnt are plain: a block
    spelling met after plain commands (the same prefix, another case) still closes its
    block, and a plain name stays a command."""
    sink = DiagnosticSink()
    text = ("MP 1\n  RSM_MACRO_SET_V X, 25\n  rsm_macro_set_v X, 25\n  IF VAR1 > 2\n"
            "    RSM_MACRO_SET_V X, 30\n  rsm_macro_end_if\n  RSM_MACRO_SET_V X, 25\nEND MP\n")
    for _ in range(2):  # the second time with every plain name learnt
        statements = parse_text(text, "a.mp", sink)
        unit = build_unit(SourceSet([SourceFile(Path("a.mp"), "a.mp", text, statements)]), sink)
        assert not sink.items, sink.items
        body = unit.programs[0].body
        assert [type(node) for node in body] == [ast.Command, ast.Command, ast.IfBlock,
                                                  ast.Command]
