"""The prepared hot lines of the interpreter (`sim.precompile`: SET_VAR, VAR_CALCULATE and IF
of 7.1, the variable commands) compute exactly what the generic handlers compute: generated
programs run on two controllers, one with the lines prepared and one without, end with the
same variables, the same error and the same number of lines run."""

from __future__ import annotations

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim import precompile
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import preload

LIMIT = 2_000_000_000  # the device's immediate range (E418 beyond)
VALUES = st.one_of(st.integers(-5, 5), st.integers(-LIMIT, LIMIT),
                   st.sampled_from([LIMIT, -LIMIT, 65535, 0x7FFF, 46341]))
VARS = st.integers(1, 6).map(lambda n: f"VAR{n}")
OPERANDS = st.one_of(VARS, VALUES.map(str))
CALC = st.tuples(VARS, OPERANDS, st.sampled_from("+-*/&|"), OPERANDS).map(
    lambda t: f"{t[0]} = {t[1]} {t[2]} {t[3]}")
SET = st.tuples(VARS, OPERANDS).map(lambda t: f"{t[0]} = {t[1]}")
IF = st.tuples(OPERANDS, st.sampled_from(["<", ">", "<=", ">=", "==", "!="]), OPERANDS,
               VARS, VALUES).map(
    lambda t: f"IF {t[0]} {t[1]} {t[2]}\n    {t[3]} = {t[4]}\n  ELSE\n    {t[3]} = {t[3]} + 1\n"
              f"  END IF")
BODY = st.lists(st.one_of(CALC, SET, IF), min_size=1, max_size=12)


def _run(source: str, prepared: bool) -> tuple[object, ...]:
    build = compile_source(source)
    assume(build.ok)
    with pytest.MonkeyPatch.context() as patch:
        if not prepared:
            patch.setattr(precompile, "prepare", lambda _vc, _t, _pc, _n, handler: handler)
        vc = VirtualController()
        preload(vc, build)
        vc.call(156)
        result = vc.run()
    return tuple(vc.vars[:8]), result.error, result.steps, result.finished


@settings(max_examples=80, deadline=None, derandomize=True)
@given(body=BODY)
def test_prepared_lines_compute_what_the_generic_handlers_compute(body: list[str]) -> None:
    lines = "\n".join(f"  VAR{n} = {n * 7 - 20}" for n in range(1, 7))
    source = "MP 156\n" + lines + "\n  FOR 3\n" + "\n".join(f"  {line}" for line in body) + \
        "\n  NEXT\nEND MP\n"
    assert _run(source, True) == _run(source, False)


def test_the_hot_lines_of_a_loop_are_prepared() -> None:
    """The arithmetic loop of bench/interp.py runs prepared closures, not the generic
    handlers, for its VAR_CALCULATE and IF lines."""
    build = compile_source("MP 156\n  FOR 3\n    VAR1 = VAR1 + 3\n    IF VAR1 > 5\n"
                           "      VAR2 = VAR1 * 2\n    END IF\n  NEXT\nEND MP\n")
    vc = VirtualController()
    preload(vc, build)
    table = vc.tables[("mp", 156)]
    program = vc._compiled(table)
    generic = {vc._calculate, vc._if, vc._set_var}
    hot = [handler for (handler, _ops, _motion), line in zip(program, table.lines, strict=True)
           if line.command.short_name in ("VAR_CALCULATE", "IF")]
    assert hot and not any(handler in generic for handler in hot)
    vc.call(156)
    assert vc.run().finished and vc.vars[1:3] == [9, 18]


def test_lines_that_do_nothing_get_no_handler() -> None:
    """END_IF and LABEL only cost their line time: they get no handler (the interpreter
    counts them and moves on), and a program with them runs as before: the same lines, the
    same time. A handler put in their place (as a test or a debugger might) is kept."""
    source = ("MP 156\n  FOR 4\n    IF VAR1 < 2\n      VAR1 = VAR1 + 1\n    END IF\n"
              "  NEXT\n  LABEL 3\n  VAR2 = VAR2 + 1\n  IF VAR2 < 3\n    GOTO 3\n  END IF\n"
              "END MP\n")
    build = compile_source(source)
    assert build.ok
    vc = VirtualController()
    preload(vc, build)
    table = vc.tables[("mp", 156)]
    names = [line.command.short_name for line in table.lines]
    assert {"END_IF", "LABEL"} <= set(names)
    for (handler, _ops, _motion), name in zip(vc._compiled(table), names, strict=True):
        assert (handler is None) == (name in ("END_IF", "LABEL")), name
    vc.call(156)
    done = vc.run()
    assert done.finished and vc.vars[1:3] == [2, 3]

    seen: list[int] = []
    other = VirtualController()
    other.handlers["END_IF"] = lambda frame, _ops: seen.append(frame.pc) or None
    preload(other, build)
    other.call(156)
    again = other.run()
    assert (again.steps, again.time_s, other.vars[1:3]) == (done.steps, done.time_s, [2, 3])
    assert seen


def _past_int32(mode: str) -> list[int]:
    """The variables after a program whose NEXT counts a variable down past -2**31 (NEXT
    does not wrap), which the lines after it copy and compute with: run by the generic
    handlers, prepared (in blocks and a compiled loop), or prepared under a hook (each line
    on its own)."""
    source = ("MP 156\n  VAR1 = 1\n  FOR VAR1\n    VAR1 = -2000000000\n"
              "    VAR1 = VAR1 - 147483648\n  NEXT\n  VAR2 = VAR1\n  VAR3 = VAR1 + 0\n"
              "  VAR4 = VAR1 * 1\n  IF VAR1 < -2000000000\n    VAR5 = VAR1\n  END IF\nEND MP\n")
    with pytest.MonkeyPatch.context() as patch:
        if mode == "generic":
            patch.setattr(precompile, "prepare", lambda _vc, _t, _pc, _n, handler: handler)
        vc = VirtualController()
        preload(vc, compile_source(source))
        if mode == "hooked":
            vc.before_line = lambda _frame: False
        vc.call(156)
        assert vc.run().finished
    return vc.vars[1:6]


def test_values_past_int32_wrap_as_the_generic_handlers_wrap_them() -> None:
    """A quick line's wrap keeps small results as they are and wraps the rest in full: a
    value one below -2**31 copies and computes to 2**31 - 1, whichever way it runs."""
    expected = [-2147483649, 2147483647, 2147483647, 2147483647, 2147483647]
    assert _past_int32("generic") == expected
    assert _past_int32("prepared") == expected
    assert _past_int32("hooked") == expected
