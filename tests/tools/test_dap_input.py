"""`mpc dap`'s expressions, in-process and property-based (bounded): conditions, evaluate
and logpoints either read or say why, never anything else. Its messages are read by the
reader both editor protocols share (tests/tools/test_framing.py)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.tools.dap import expr

FAST = settings(max_examples=150, deadline=None, database=None, derandomize=True)


@FAST
@given(st.text(max_size=200))
def test_evaluate_any_text_reads_or_says_why(text: str) -> None:
    try:
        tree = expr.parse(text)
    except expr.ExpressionError as exc:
        assert str(exc)
        return
    try:
        value = expr.evaluate(tree, lambda name: 7 if name != "missing" else None)
    except expr.ExpressionError as exc:
        assert str(exc)
        return
    assert isinstance(value, int)


@FAST
@given(st.integers(-2**31, 2**31 - 1), st.integers(-2**31, 2**31 - 1),
       st.sampled_from(["+", "-", "*", "/", "&", "|"]))
def test_evaluate_uses_the_device_arithmetic(left: int, right: int, op: str) -> None:
    """C division and the 32-bit wrap of VAR_CALCULATE (device profile [arithmetic])."""
    from mplang.ir.fold import apply_operator

    values = {"a": left, "b": right}
    tree = expr.parse(f"a {op} b")
    if op == "/" and right == 0:
        try:
            expr.evaluate(tree, values.get)
        except expr.ExpressionError as exc:
            assert "division by zero" in str(exc)
            return
        raise AssertionError("division by zero gave a value")
    assert expr.evaluate(tree, values.get) == apply_operator(op, left, right)


def test_evaluate_conditions_as_breakpoints_write_them() -> None:
    values = {"rows_done": 4, "VAR12": 0}
    for text, expected in (("rows_done > 3", 1), ("VAR12 == 0", 1),
                           ("rows_done > 3 && VAR12 != 0", 0), ("!VAR12", 1),
                           ("rows_done >= 4 || missing", 1), ("-rows_done", -4)):
        assert expr.evaluate(expr.parse(text), values.get) == expected, text
    assert expr.names(expr.parse("a + VAR3 * b")) == ["a", "VAR3", "b"]


def test_evaluate_an_axis_counter_by_a_dotted_name() -> None:
    values = {"X.LP": 1200, "rows": 2}
    assert expr.evaluate(expr.parse("X.LP / rows"), values.get) == 600
    assert expr.names(expr.parse("X.LP + Y.EP * rows")) == ["X.LP", "Y.EP", "rows"]
    for text in ("X.LP.more", "f(x).LP"):
        try:
            expr.parse(text)
        except expr.ExpressionError as exc:
            assert "X.LP" in str(exc) or "not a variable" in str(exc)
        else:
            raise AssertionError(f"{text!r} was read")
