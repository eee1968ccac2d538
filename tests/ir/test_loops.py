"""WHILE and REPEAT: what they lower to, and that they run as written on the virtual
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
