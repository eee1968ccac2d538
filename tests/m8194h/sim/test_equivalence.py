"""Random programs behave the same from the image (interpreter over decoded frames) and in a
small independent evaluator of their syntax tree, for the arithmetic/control subset."""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mplang.ir.fold import apply_operator
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import run_build

VARS = [1, 2, 3, 4, 5, 6]


@dataclass
class Assign:
    target: int
    expr: str  # Python-compatible infix text over VARn names


@dataclass
class If:
    left: int
    op: str
    right: int
    then: list[object]
    otherwise: list[object] | None


@dataclass
class For:
    count: int
    body: list[object]


leaf = st.one_of(st.integers(-20, 20).map(str), st.sampled_from([f"VAR{v}" for v in VARS]))
expr = st.recursive(leaf, lambda c: st.tuples(c, st.sampled_from("+-*/&|"), c).map(
    lambda t: f"({t[0]} {t[1]} {t[2]})"), max_leaves=5)
assign = st.builds(Assign, st.sampled_from(VARS), expr)


def blocks(depth: int) -> st.SearchStrategy[list[object]]:
    statement: st.SearchStrategy[object] = assign
    if depth > 0:
        inner = st.deferred(lambda: blocks(depth - 1))
        statement = st.one_of(
            assign,
            st.builds(If, st.sampled_from(VARS), st.sampled_from(["<", ">", "<=", ">=", "==",
                                                                  "!="]),
                      st.integers(-10, 10), inner, st.one_of(st.none(), inner)),
            st.builds(For, st.integers(0, 3), inner),
        )
    return st.lists(statement, min_size=1, max_size=4)


def render(body: list[object], indent: str = "  ") -> str:
    out = ""
    for node in body:
        if isinstance(node, Assign):
            out += f"{indent}VAR{node.target} = {node.expr}\n"
        elif isinstance(node, If):
            out += f"{indent}IF VAR{node.left} {node.op} {node.right}\n"
            out += render(node.then, indent + "  ")
            if node.otherwise is not None:
                out += f"{indent}ELSE\n" + render(node.otherwise, indent + "  ")
            out += f"{indent}END IF\n"
        elif isinstance(node, For):
            out += f"{indent}FOR {node.count}\n" + render(node.body, indent + "  ")
            out += f"{indent}NEXT\n"
    return out


def evaluate_expr(text: str, env: dict[int, int]) -> int:
    import ast as pyast

    def ev(node: pyast.expr) -> int:
        if isinstance(node, pyast.Constant):
            return int(node.value)
        if isinstance(node, pyast.Name):
            return env[int(node.id[3:])]
        if isinstance(node, pyast.UnaryOp):
            return -ev(node.operand)
        assert isinstance(node, pyast.BinOp)
        op = {pyast.Add: "+", pyast.Sub: "-", pyast.Mult: "*", pyast.Div: "/",
              pyast.BitAnd: "&", pyast.BitOr: "|"}[type(node.op)]
        return apply_operator(op, ev(node.left), ev(node.right))

    return ev(pyast.parse(text, mode="eval").body)


def evaluate(body: list[object], env: dict[int, int]) -> None:
    for node in body:
        if isinstance(node, Assign):
            env[node.target] = evaluate_expr(node.expr, env)
        elif isinstance(node, If):
            left = env[node.left]
            holds = {"<": left < node.right, ">": left > node.right,
                     "<=": left <= node.right, ">=": left >= node.right,
                     "==": left == node.right, "!=": left != node.right}[node.op]
            if holds:
                evaluate(node.then, env)
            elif node.otherwise is not None:
                evaluate(node.otherwise, env)
        elif isinstance(node, For):
            for _ in range(node.count):
                evaluate(node.body, env)


@settings(max_examples=150, deadline=None)
@given(blocks(2))
def test_image_and_syntax_tree_agree(body: list[object]) -> None:
    env = {v: 0 for v in VARS}
    setup = "".join(f"  VAR{v} = {v * 3 - 7}\n" for v in VARS)
    for v in VARS:
        env[v] = v * 3 - 7
    try:
        evaluate(body, env)
    except ZeroDivisionError:
        assume(False)
    build = compile_source(f"MP 156\n{setup}{render(body)}END MP\n")
    assume(build.ok)  # folded constants beyond +/-2e9 are compile errors by design
    report = run_build(build)
    assert report.result.finished, report.result.error
    assert {v: report.controller.vars[v] for v in VARS} == env
