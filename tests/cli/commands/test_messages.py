"""Messages that said the wrong thing (issue 15 item 6), each as a user meets it on the
command line: the message names what is wrong and the hint what to write instead
(docs/language.md "Statements", "Expressions", "INCLUDE and the library"; docs/cli.md for
`mpc build`, `mpc import` and the listing)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_NO_INPUT, EXIT_OK, EXIT_SOURCE_ERRORS, EXIT_USAGE, main


@pytest.fixture()
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder without a project file, as the current directory."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def lint(here: Path, text: str, *args: str) -> tuple[int, str]:
    (here / "job.mp").write_text(text)
    result = CliRunner().invoke(main, ["lint", "job.mp", *args])
    return result.exit_code, result.output


def program(*lines: str) -> str:
    return "MP 1 job\n" + "".join(f"    {line}\n" for line in lines) + "END MP\n"


def errors(output: str) -> list[str]:
    return re.findall(r"^\S+: error\[\w+\]: .*$", output, re.MULTILINE)


def test_temp_vars_reversed_range_says_it_is_reversed(here: Path) -> None:
    (here / "job.mp").write_text(program("VAR1 = 1"))
    result = CliRunner().invoke(main, ["build", "job.mp", "--temp-vars", "511-500"])
    assert result.exit_code == EXIT_USAGE
    assert "511-500: the range is reversed (FIRST after LAST): write 500-511" in result.output
    assert "must lie within" not in result.output
    outside = CliRunner().invoke(main, ["build", "job.mp", "--temp-vars", "600-700"])
    assert "the pool must lie within VAR0..VAR511" in outside.output  # still said where true


def test_statements_timer_with_a_decimal_point_names_the_unit(here: Path) -> None:
    code, output = lint(here, program("TIMER 1.5"))
    assert code == EXIT_SOURCE_ERRORS
    assert "error[E101]: '1.5': mplang numbers are whole numbers (no decimal point)" in output
    assert "hint: write TIMER's varNo as a whole number: Delay in ms" in output
    assert "remove it" not in output  # removing the '.' makes it 15


def test_statements_compound_assignment_hint_writes_it_out(here: Path) -> None:
    code, output = lint(here, program("VAR1 = 0", "VAR1 += 1", "VAR2 -= VAR1 * 2"))
    assert code == EXIT_SOURCE_ERRORS
    assert "'+=' is not an mplang operator" in output
    assert "hint: write VAR1 = VAR1 + 1" in output
    assert "hint: write VAR2 = VAR2 - VAR1 * 2" in output
    assert "one statement per line" not in output


def test_statements_and_or_in_a_condition_say_to_nest_ifs(here: Path) -> None:
    code, output = lint(here, program("IF VAR1 > 0 AND VAR2 > 0", "END IF",
                                      "IF VAR1 > 0 or VAR2 > 0", "END IF"))
    assert code == EXIT_SOURCE_ERRORS
    assert output.count("AND and OR are not supported in conditions: IF compares two "
                        "values") == 2
    assert "for AND nest the IFs" in output
    assert "one statement per line" not in output


def test_statements_else_if_says_else_and_a_nested_if(here: Path) -> None:
    code, output = lint(here, program("IF VAR1 > 0", "ELSE IF VAR1 < 0", "END IF"))
    assert code == EXIT_SOURCE_ERRORS
    assert "ELSE IF is not an mplang form: ELSE stands alone on its line" in output
    assert "write ELSE, then the IF on the next line inside it" in output


def test_commands_enum_argument_lists_the_accepted_names(here: Path) -> None:
    code, output = lint(here, program("AXIS_ASSIGN X, Y, 0",
                                      "MIX_2D_CONTINUE 0, ARC_CX, 100, 100, 0, 0"))
    assert code == EXIT_SOURCE_ERRORS
    assert "unknown name 'ARC_CX'; MIX_2D_CONTINUE nType takes one of LINE_2D (1), ARC_CW " \
        "(2), ARC_CCW (3), CIRCLE_CW (4), CIRCLE_CCW (5)" in output
    assert "hint: did you mean ARC_CW?" in output
    _, numbers = lint(here, program("SET_PULSE_MODE X, FAST"))
    assert "SET_PULSE_MODE nMode takes one of 0, 1, 2, 3, 4, 5" in numbers
    assert "hint: write one of these numbers, or a CONST that holds one" in numbers


def test_include_missing_file_is_one_error_at_the_include(here: Path) -> None:
    code, output = lint(here, 'INCLUDE "nothere.mp"\n' + program(
        "SET_V X, SPEED", "FIXED_MOVE X, DIST", "count = count + 1", "CALL helper"))
    assert code == EXIT_SOURCE_ERRORS
    assert errors(output) == ["job.mp:1:1: error[E102]: cannot include nothere.mp: No such "
                              "file or directory"]
    assert "4 errors about names it may define are left out until it is found" in output
    _, csim = lint(here, 'INCLUDE "nothere.mp"\n' + program("FIXED_MOVE X, DIST"),
                   "--target", "csim")
    assert [e.split(": error")[0] for e in errors(csim)] == ["job.mp:1:1"]


def test_include_library_without_its_consts_is_one_error_naming_them(here: Path) -> None:
    code, output = lint(here, 'INCLUDE "std:circle.mp"\n' + program(
        "std_circle_laps = 2", "CALL std_circle"))
    assert code == EXIT_SOURCE_ERRORS
    assert errors(output) == [
        "job.mp:1:1: error[E202]: std:circle.mp needs CONSTs the including program defines, "
        "and these are missing: STD_CIRCLE_AXIS1, STD_CIRCLE_AXIS2, STD_CIRCLE_VSV, "
        "STD_CIRCLE_VV, STD_CIRCLE_VA, STD_CIRCLE_CX, STD_CIRCLE_CY"]
    assert "did you mean" not in output
    some = "".join(f"CONST STD_CIRCLE_{n} = {v}\n" for n, v in
                   (("AXIS1", 1), ("AXIS2", 2), ("VSV", 100), ("VV", 1000), ("VA", 10000)))
    _, fewer = lint(here, some + 'INCLUDE "std:circle.mp"\n' + program("CALL std_circle"))
    assert "this is missing" not in fewer and "these are missing: STD_CIRCLE_CX, " \
        "STD_CIRCLE_CY" in fewer


def test_build_and_run_of_an_image_say_it_is_an_image(here: Path) -> None:
    (here / "job.mp").write_text(program("SET_V X, 1000", "FIXED_MOVE X, 100"))
    built = CliRunner().invoke(main, ["build", "job.mp", "-o", "job.image.json"])
    assert built.exit_code == EXIT_OK, built.output
    for command in ("build", "run", "lint"):
        result = CliRunner().invoke(main, [command, "job.image.json"])
        assert result.exit_code == EXIT_NO_INPUT
        assert "job.image.json: a built image (the JSON `mpc build` writes), not a source: " \
            "flash it with `mpc flash job.image.json --tcp HOST`" in result.output
        assert "mpc disasm job.image.json" in result.output
        assert "E101" not in result.output


def test_import_of_c_without_vendor_calls_is_an_error(here: Path) -> None:
    (here / "plain.c").write_text('/* RSM_MP_CREATE( in a comment */\nint main(void) {\n'
                                  '    puts("ETM_SET_V(");\n    return 0;\n}\n')
    result = CliRunner().invoke(main, ["import", "plain.c"])
    assert result.exit_code == EXIT_NO_INPUT
    assert "plain.c: no call of the vendor API" in result.output
    (here / "one.c").write_text("void f(HANDLE h) {\n    RSM_MP_CREATE(h, 1, 1);\n"
                                "    RSM_MACRO_SET_V(h, 1, AXIS_X, 1000);\n"
                                "    RSM_MACRO_MP_CLOSE(h, 1);\n}\n")
    assert CliRunner().invoke(main, ["import", "one.c"]).exit_code == EXIT_OK


def test_listing_columns_hold_for_a_sixty_character_path(here: Path) -> None:
    name = "cell_seven_of_the_packaging_line/" + "x" * 24 + ".mp"
    assert len(name) == 60
    (here / name).parent.mkdir()
    (here / name).write_text(program("SET_V X, 1000", "FIXED_MOVE X, 100"))
    result = CliRunner().invoke(main, ["build", name, "--format", "listing"])
    assert result.exit_code == EXIT_OK, result.output
    rows = [line for line in result.output.splitlines() if line.startswith(f"  {name}:")]
    assert len(rows) == 3
    header = next(line for line in result.output.splitlines() if "lines cost  frame" in line)
    cost, frame = header.index("cost") + len("cost"), header.index("frame")
    for row in rows:
        assert row[cost - 1] == "1" and row[frame:frame + 2] == "0C"  # right under the heads
        assert row.index("SET_V" if "0C48" in row else "FIXED_MOVE" if "0C4E" in row
                         else "END MP") == rows[0].index("SET_V")
