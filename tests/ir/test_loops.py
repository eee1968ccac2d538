"""FOR, WHILE and REPEAT: what they lower to, and that they run as written on the virtual
controller (hypothesis picks the counts)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import BuildResult, compile_source
from mplang.m8194h.run import run_build


def build(source: str) -> BuildResult:
    result = compile_source(source, "loops.mp")
    assert result.ok, [d.render() for d in result.diagnostics]
    return result


def commands(result: BuildResult) -> list[str]:
    return [line.line.command.short_name for line in result.programs[0].lines]


def final_vars(result: BuildResult, call: str) -> dict[str, int]:
    outcome = run_build(result, call, None)
    assert outcome.result.finished, outcome.result.error
    variables: dict[str, int] = outcome.to_json()["vars"]  # type: ignore[assignment]
    return variables


def test_while_lowers_to_one_label_an_if_and_a_jump_back() -> None:
    result = build("MP 41 w\n    VAR1 = 0\n    WHILE VAR1 < 5\n        VAR1 = VAR1 + 1\n"
                   "    END WHILE\nEND MP\n")
    assert commands(result) == ["SET_VAR", "LABEL", "IF", "VAR_CALCULATE", "GOTO", "END_IF"]


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 40), st.integers(1, 5))
def test_while_tests_its_condition_afresh_every_round(limit: int, step: int) -> None:
    """The condition is an expression (computed through a temporary after the label), so
    a stale value would loop forever or stop early."""
    result = build(f"""VAR limit @ VAR10
MP 91 counting
    limit = {limit}
    VAR1 = 0
    VAR2 = 0
    WHILE VAR1 < limit * 1 + 0
        VAR1 = VAR1 + {step}
        VAR2 = VAR2 + 1
    END WHILE
END MP
""")
    got = final_vars(result, "counting")
    rounds = -(-limit // step)  # ceil: the rounds until VAR1 >= limit
    assert got.get("VAR2", 0) == rounds
    assert got.get("VAR1", 0) == rounds * step


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 30))
def test_repeat_runs_n_times_and_keeps_its_count_variable(times: int) -> None:
    result = build(f"""MP 41 rep
    VAR5 = {times}
    VAR6 = 0
    REPEAT VAR5
        VAR6 = VAR6 + 1
    END REPEAT
END MP
""")
    got = final_vars(result, "rep")
    assert got.get("VAR6", 0) == times and got.get("VAR5", 0) == times


def test_repeat_with_a_constant_is_a_plain_for_and_nests() -> None:
    result = build("""MP 41 grid
    VAR1 = 0
    REPEAT 3
        REPEAT 4
            VAR1 = VAR1 + 1
        END REPEAT
    END REPEAT
END MP
""")
    assert commands(result).count("FOR") == 2
    assert final_vars(result, "grid")["VAR1"] == 12


def test_a_while_and_named_labels_share_the_four_labels() -> None:
    result = build("""MP 91 mixed
    VAR1 = 0
    LABEL again
    WHILE VAR1 < 3
        VAR1 = VAR1 + 1
    END WHILE
    VAR2 = VAR2 + 1
    IF VAR2 < 2
        GOTO again
    END IF
END MP
""")
    labels = [line.line.operands for line in result.programs[0].lines
              if line.line.command.short_name == "LABEL"]
    assert len(labels) == 2 and labels[0] != labels[1]
    assert final_vars(result, "mixed")["VAR2"] == 2


def test_label_inside_a_while_body_says_why() -> None:
    result = compile_source("MP 41 w\n    VAR1 = 0\n    WHILE VAR1 < 2\n        LABEL x\n"
                            "        VAR1 = VAR1 + 1\n    END WHILE\nEND MP\n")
    [problem] = [d for d in result.diagnostics if d.code == "E323"]
    assert "WHILE block (its body is inside an IF)" in problem.message


# ------------------------------------------------ FOR: nesting, ISRs, counts (docs/testing.md)
def nested_fors(depth: int, extra: str = "") -> str:
    """MP131 (64 lines) with `depth` FORs nested, then `extra` lines at the top level."""
    opening = "".join(f"{'    ' * (n + 1)}FOR 2\n" for n in range(depth))
    closing = "".join(f"{'    ' * (n + 1)}NEXT\n" for n in reversed(range(depth)))
    return (f"MP 131 deep\n{opening}{'    ' * (depth + 1)}FIXED_MOVE X, 10\n{closing}{extra}"
            "END MP\n")


def test_seven_nested_fors_are_allowed_and_the_eighth_is_reported_once() -> None:
    """The profile's for_depth is 7 (ET 16778: seven levels, one outer and six inner);
    E311 stands on the FOR that passes it, once, however deep the nesting goes."""
    seven = build(nested_fors(7))
    assert commands(seven) == ["FOR"] * 7 + ["FIXED_MOVE"] + ["NEXT"] * 7
    for depth, line in ((8, 9), (9, 9)):
        diagnostics = compile_source(nested_fors(depth), "loops.mp").diagnostics
        assert [(d.code, d.span.line) for d in diagnostics] == [("E311", line)], depth
        assert diagnostics[0].message == ("FOR nested 8 deep; the device allows 7 (one "
                                          "outer and 6 inner)")


def test_fors_side_by_side_do_not_add_up() -> None:
    assert build(nested_fors(7, "    FOR 2\n        FIXED_MOVE X, 1\n    NEXT\n")).ok


def test_a_for_in_an_isr_is_refused_and_its_body_still_checked() -> None:
    diagnostics = compile_source("ISR 1 on_event\n    FOR 3\n        FIXED_MOVE X, 100\n"
                                 "        VAR1 = NOPE\n    NEXT\nEND ISR\n",
                                 "loops.mp").diagnostics
    assert (diagnostics[0].code, diagnostics[0].span.line) == ("E313", 2)
    assert diagnostics[0].message == "FOR loops are not allowed in an ISR"
    assert any(d.span.line == 4 for d in diagnostics[1:])  # the body was lowered too


def test_a_for_that_never_runs_is_a_warning_that_names_its_count() -> None:
    result = compile_source("MP 41 main\n    FOR 0\n        FIXED_MOVE X, 1\n    NEXT\n"
                            "    FOR -3\n        FIXED_MOVE X, 1\n    NEXT\n    FOR 1\n"
                            "        FIXED_MOVE X, 1\n    NEXT\nEND MP\n", "loops.mp")
    assert [(d.code, d.span.line, d.message) for d in result.diagnostics] == [
        ("W102", 2, "FOR 0 never runs its body"), ("W102", 5, "FOR -3 never runs its body")]
    assert commands(result) == ["FOR", "FIXED_MOVE", "NEXT"] * 3


def test_a_for_counted_by_a_variable_sends_it_and_the_device_counts_it_down() -> None:
    """FOR VARn: the operand is the variable, which the device decrements to zero; the
    loop runs its value's number of times."""
    result = build("MP 1 main\n    VAR2 = 4\n    VAR3 = 0\n    FOR VAR2\n"
                   "        VAR3 = VAR3 + 1\n    NEXT\nEND MP\n")
    assert commands(result) == ["SET_VAR", "SET_VAR", "FOR", "VAR_CALCULATE", "NEXT"]
    assert final_vars(result, "MP1")["VAR3"] == 4


def test_exit_for_leaves_the_loop_it_stands_in() -> None:
    result = build("MP 41 main\n    FOR 3\n        VAR1 = VAR1 + 1\n        EXIT FOR\n"
                   "    NEXT\nEND MP\n")
    assert commands(result) == ["FOR", "VAR_CALCULATE", "EXIT_FOR", "NEXT"]


def test_a_for_count_that_cannot_be_computed_is_one_error() -> None:
    """A constant count that divides by zero is E206 (docs/checks/E206.md), reported once;
    the FOR goes on to be checked as a loop with no count."""
    diagnostics = compile_source("MP 1 main\n    FOR 1 / 0\n        FIXED_MOVE X, 1\n"
                                 "    NEXT\nEND MP\n", "loops.mp").diagnostics
    assert [(d.code, d.span.line) for d in diagnostics] == [("E206", 2)]
