"""Lowering: expressions through temporaries compute what the source says.

A tiny evaluator runs the SET_VAR / VAR_CALCULATE / SET_RVAR lines of the IR; its result must
equal a direct evaluation of the expression with the device's arithmetic (C division,
32-bit wrap). The full interpreter (issue 3) will run frames; this checks the lowering alone.
"""

from __future__ import annotations

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mplang.ir import catalogue
from mplang.ir.fold import apply_operator
from mplang.ir.macro import MacroLine, Operand, VarRef
from mplang.m8194h.compiler import Options, compile_source

CAT = catalogue.load()
OPS = {v: k for k, v in CAT.profile.calc_ops.items()}
INITIAL = {1: 7, 2: -3, 3: 1000, 4: 0}


def run_lines(lines: list[MacroLine], variables: dict[int, int]) -> dict[int, int]:
    def value(operand: Operand) -> int:
        return variables.get(operand.index, 0) if isinstance(operand, VarRef) else int(operand)

    for line in lines:
        name, ops = line.command.short_name, line.operands
        if name == "SET_VAR":
            assert isinstance(ops[0], VarRef)
            variables[ops[0].index] = value(ops[1])
        elif name == "VAR_CALCULATE":
            assert isinstance(ops[3], VarRef)
            variables[ops[3].index] = apply_operator(OPS[int(ops[1])], value(ops[0]),
                                                     value(ops[2]))
        else:
            raise AssertionError(f"unexpected {name}")
    return variables


leaves = st.one_of(st.integers(-50, 50).map(str), st.sampled_from(["VAR1", "VAR2", "VAR3",
                                                                     "VAR4", "K"]))


def trees(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.tuples(children, st.sampled_from("+-*/&|"), children).map(
            lambda t: f"({t[0]} {t[1]} {t[2]})"),
        children.map(lambda c: f"-{c}" if not c.startswith("-") else c),
    )


expressions = st.recursive(leaves, trees, max_leaves=8)


def reference(text: str) -> int:
    """Evaluate with the device's arithmetic by turning the text into nested calls."""
    import ast as pyast

    env = {f"VAR{k}": v for k, v in INITIAL.items()} | {"K": 12}

    def ev(node: pyast.expr) -> int:
        if isinstance(node, pyast.Constant):
            return int(node.value)
        if isinstance(node, pyast.Name):
            return env[node.id]
        if isinstance(node, pyast.UnaryOp):
            return apply_operator("-", 0, ev(node.operand))
        assert isinstance(node, pyast.BinOp)
        op = {pyast.Add: "+", pyast.Sub: "-", pyast.Mult: "*", pyast.Div: "/",
              pyast.BitAnd: "&", pyast.BitOr: "|"}[type(node.op)]
        return apply_operator(op, ev(node.left), ev(node.right))

    return ev(pyast.parse(text, mode="eval").body)


@settings(max_examples=300, deadline=None)
@given(expressions, st.sampled_from([1, 5]))
def test_expression_lowering_matches_direct_evaluation(expr: str, target: int) -> None:
    try:
        expected = reference(expr)
    except ZeroDivisionError:
        assume(False)
    source = f"CONST K = 12\nMP 156\n  VAR{target} = {expr}\nEND MP\n"
    result = compile_source(source, options=Options(temps=range(500, 512)))
    assume(result.ok)  # constant parts beyond +/-2e9 are rejected (E418) by design
    lines = [lf.line for lf in result.programs[0].lines]
    variables = run_lines(lines, dict(INITIAL))
    assert variables[target] == expected
    touched = {op.index for line in lines for op in line.operands if isinstance(op, VarRef)}
    assert touched <= set(INITIAL) | {target} | set(range(500, 512))


def test_constant_folding_and_simple_forms() -> None:
    result = compile_source("CONST A = 2000 * 2\nMP 1\n VAR1 = A / 3 - 1\n VAR2 = VAR1\n"
                            " VAR3 = VAR1 * VAR2\nEND MP\n")
    assert result.ok
    frames = result.programs[0].frames
    assert frames[1] == [0x0CD2, 0x7FFF, 1, 0, 1332]  # folded: 4000 / 3 - 1
    assert frames[2] == [0x0CD2, 0x7FFF, 2, 0x7FFF, 1]  # VAR2 = VAR1
    assert frames[3] == [0x0CD4, 0x7FFF, 1, 0x2A, 0x7FFF, 2, 0x7FFF, 3]


def test_query_assignment_emits_read_then_set_rvar() -> None:
    result = compile_source("MP 1\n VAR5 = GET_LP(X)\nEND MP\n")
    assert result.ok
    assert result.programs[0].frames[1:3] == [[0x0C29, 1], [0x0CD3, 0x7FFF, 5]]


def test_c_division_truncates_toward_zero() -> None:
    assert apply_operator("/", -7, 2) == -3
    assert apply_operator("/", 7, -2) == -3
    assert apply_operator("*", 2_000_000_000, 2) == -294_967_296  # 32-bit wrap


def test_temporary_pool_exhaustion_is_reported() -> None:
    deep = "VAR1"
    for _ in range(4):
        deep = f"(VAR2 * {deep}) + (VAR3 * {deep})"
    result = compile_source(f"MP 156\n VAR9 = {deep}\nEND MP\n",
                            options=Options(temps=range(510, 512)))
    assert "E422" in {d.code for d in result.diagnostics}


def test_bare_zero_argument_query() -> None:
    with_brackets = compile_source("MP 1\n VAR1 = GET_ERROR()\nEND MP\n")
    bare = compile_source("MP 1\n VAR1 = GET_ERROR\nEND MP\n")
    assert bare.ok and bare.programs[0].frames == with_brackets.programs[0].frames


def test_program_name_must_be_of_the_right_kind() -> None:
    result = compile_source("MP 41 big\n EXIT\nEND MP\nMP 1\n INTFACTOR_ENABLE X, 4, big\n"
                            "END MP\n")
    assert [d.code for d in result.diagnostics] == ["E416"]


def test_only_warnings_can_be_silenced() -> None:
    source = "MP 1\n VAR2 = VAR1   # mpc: ignore[W103]\n VAR3 = VAR9 # mpc: ignore\n" \
             " FOO 1 # mpc: ignore\nEND MP\n"
    assert [d.code for d in compile_source(source).diagnostics] == ["E201"]


def _temporaries(program_lines: list[MacroLine]) -> set[int]:
    return {o.index for line in program_lines for o in line.operands
            if isinstance(o, VarRef) and 500 <= o.index < 512}


def test_isrs_compute_in_their_own_temporaries() -> None:
    # An ISR runs between two lines of the MP it interrupts: sharing a temporary would
    # overwrite the MP's half-computed expression.
    source = """MP 41 main
    VAR1 = (VAR2 + 1) * (VAR3 + 2) * (VAR4 + 3) - (VAR5 + 4) * (VAR6 + 5)
END MP
ISR 7 tick
    VAR7 = (VAR8 + 1) * (VAR9 + 2) - VAR10
END ISR
"""
    result = compile_source(source)
    assert result.ok, [d.render() for d in result.diagnostics]
    by_kind = {p.program.kind: _temporaries([lf.line for lf in p.lines])
               for p in result.programs}
    assert by_kind["mp"] and by_kind["isr"]
    assert not by_kind["mp"] & by_kind["isr"]
    assert by_kind["isr"] <= set(range(509, 512)) and by_kind["mp"] <= set(range(500, 509))


def test_isr_expression_too_big_for_its_share_names_the_share() -> None:
    deep = "VAR9 + 1"
    for n in range(1, 6):
        deep = f"(VAR{n} + 1) * ({deep})"
    source = f"ISR 7 tick\n    VAR20 = {deep}\nEND ISR\n"
    result = compile_source(source)
    messages = [d.message for d in result.diagnostics if d.code == "E422"]
    assert messages and "an ISR may use (VAR509..VAR511)" in messages[0]


def test_const_from_unknown_name_names_it() -> None:
    result = compile_source("CONST SPEED = 10\nCONST A = SPEDE * 2\nCONST B = VAR3 + 1\n")
    found = {(d.message, d.hint) for d in result.diagnostics if d.code == "E206"}
    assert ("CONST A uses SPEDE, which is not defined, so it is not a constant",
            "did you mean SPEED?") in found
    assert any("CONST B uses VAR3, which is a variable" in message for message, _ in found)


def test_repeated_arguments_resolve_alike_and_each_place_reports_its_own() -> None:
    """A program resolves a constant argument once per parameter and value: every copy of
    a line compiles to the same operands, and a refused value is reported at each place,
    as is a variable read before it is written (never taken from an earlier copy)."""
    lines = ["MP 156 main", *["  SET_V X, 2000", "  SET_V Y, 3000000000", "  SET_V X, VAR7",
                            "  SET_V X, SPEED"] * 3, "END MP", ""]
    result = compile_source("\n".join(["CONST SPEED = 300", *lines]), "repeat.mp")
    refused = [d.span.line for d in result.diagnostics if d.code == "E418"]
    assert refused == [4, 8, 12]
    assert [d.span.line for d in result.diagnostics if d.code == "W103"] == [5]
    fine = "\n".join(line for line in ["CONST SPEED = 300", *lines] if "SET_V Y" not in line)
    built = compile_source(fine, "fine.mp")
    assert built.ok
    operands = [line.operands for line in built.programs[0].placement.program.lines
                if line.command.short_name == "SET_V"]
    assert operands == [(1, 2000), (1, VarRef(7)), (1, 300)] * 3
