"""The statement writer shared by `mpc disasm` and `mpc import`: fewest brackets, same tree;
every single-line statement compiles back to exactly its line."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.ir import catalogue
from mplang.ir.macro import MacroLine, Operand, VarRef
from mplang.ir.mpwriter import Bin, Expr, Leaf, Writer, render_expr
from mplang.lang.diagnostics import Span
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.encode import Encoder

CAT = catalogue.load()
WRITER = Writer(CAT)

leaves = st.one_of(st.integers(-9, 9).map(lambda n: Leaf(str(n), n)),
                   st.integers(1, 4).map(lambda n: Leaf(f"VAR{n}", VarRef(n))))
trees = st.recursive(leaves, lambda inner: st.builds(Bin, st.sampled_from("+-*/&|"), inner,
                                                     inner), max_leaves=6)


def bracketed(expr: Expr) -> str:
    if isinstance(expr, Bin):
        return f"({bracketed(expr.left)} {expr.op} {bracketed(expr.right)})"
    assert isinstance(expr, Leaf)
    return expr.text


@settings(max_examples=200, deadline=None)
@given(trees)
def test_fewest_brackets_keep_the_tree(tree: Expr) -> None:
    def frames(text: str) -> list[list[int]]:
        build = compile_source(f"MP 156\n VAR9 = {text}\nEND MP\n", "t.mp")
        assert build.ok or not any(d.code == "E101" for d in build.diagnostics)
        return build.programs[0].frames if build.ok else []

    assert frames(render_expr(tree)) == frames(bracketed(tree))


def test_brackets_only_where_needed() -> None:
    a, b, c = (Leaf(f"VAR{n}", VarRef(n)) for n in (1, 2, 3))
    assert render_expr(Bin("-", a, Bin("-", b, c))) == "VAR1 - (VAR2 - VAR3)"
    assert render_expr(Bin("-", Bin("-", a, b), c)) == "VAR1 - VAR2 - VAR3"
    assert render_expr(Bin("*", Bin("+", a, b), c)) == "(VAR1 + VAR2) * VAR3"
    assert render_expr(Bin("|", a, Bin("&", b, c))) == "VAR1 | VAR2 & VAR3"


LINES = [
    ("SET_VAR", (VarRef(1), -5), "VAR1 = -5"),
    ("SET_VAR", (VarRef(1), VarRef(2)), "VAR1 = VAR2"),
    ("VAR_CALCULATE", (VarRef(1), 0x2D, -5, VarRef(1)), "VAR1 = VAR1 - -5"),
    ("VAR_CALCULATE", (0, 0x2D, VarRef(2), VarRef(3)), "VAR3 = 0 - VAR2"),
    ("VAR_CALCULATE", (7, 0x2B, 3, VarRef(3)), "VAR_CALCULATE 7, '+', 3, VAR3"),
    ("IF", (VarRef(1), 0x3D3C, 5), "IF VAR1 <= 5"),
    ("IF", (3, 0x003C, 5), "IF 3 < 5"),
    ("IF", (VarRef(1), 0x3C3D, 5), "RSM_MACRO_IF VAR1, 15421, 5"),
    ("FOR", (-1,), "FOR -1"),
    ("LABEL", (2,), "LABEL 2"),
    ("MP_CALL", (21,), "CALL MP21"),
    ("SET_ACTIVATION_AXIS", (1, 2), "SET_ACTIVATION_AXIS X, Y"),
    ("INTFACTOR_ENABLE", (1, 4, 3), "INTFACTOR_ENABLE X, 4, ISR3"),
    ("RSM_SET_V", (1, 2000), "RSM_SET_V X, 2000"),
]


@pytest.mark.parametrize("name, operands, text", LINES, ids=[t for _, _, t in LINES])
def test_statement_spelling(name: str, operands: tuple[Operand, ...], text: str) -> None:
    command = CAT.lookup(name)
    assert command is not None
    assert WRITER.statement(command, operands) == text
    if not command.is_macro or text.startswith("RSM_MACRO_IF"):
        return  # the compiler refuses these, as it should: mpc disasm names them
    body = text
    if name in ("IF", "FOR"):
        body += "\nEND IF" if name == "IF" else "\nNEXT"
    build = compile_source(f"MP 156\n{body}\nEND MP\n", "t.mp")
    assert build.ok, [d.render() for d in build.diagnostics]
    expected = Encoder(CAT).frame(MacroLine(command, operands, Span("t.mp", 1)))
    assert build.programs[0].lines[0].frame == expected
