"""`mpc import`: vendor-API C programs to `.mp`.

The manual's worked examples, transcribed from its C listings (tests/data/import/manual_*.c),
must import without omissions and build to exactly the frames the manual prints
(tests/data/manual_examples.toml). A whole C program with host code, comments, an MP and an
ISR imports to the program a person would write, and every construct that cannot be
converted is named with its line.
"""

from __future__ import annotations

import re
import tomllib
from functools import cache
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.cli import main
from mplang.ir import catalogue
from mplang.ir.catalogue import Param
from mplang.ir.macro import BVarRef, Operand, VarRef
from mplang.m8194h.compiler import BuildResult, Options, compile_paths, compile_source
from mplang.m8194h.encode import Encoder
from mplang.m8194h.importc import Conversion, Unconvertible, convert, read_c_file
from mplang.m8194h.importc import _number as c_number

DATA = Path(__file__).resolve().parents[1] / "data"
IMPORT = DATA / "import"
EXAMPLES: list[dict[str, Any]] = tomllib.loads((DATA / "manual_examples.toml").read_text())[
    "example"]
MANUAL_FILES = sorted(IMPORT.glob("manual_*.c"))
MARKER = re.compile(r"_MP(_ISR)?_CREATE\s*\(\s*\w+\s*,\s*\w+\s*,\s*(?:MP|ISR)(\d+)\s*\)\s*;"
                    r"\s*//\s*example RS (\d+)")
CAT = catalogue.load()


@cache
def imported(path: Path, target: str = "rs") -> tuple[Conversion, BuildResult]:
    conversion = convert(path.read_text(encoding="utf-8"), source_name=path.name)
    build = compile_source(conversion.text, path.with_suffix(".mp").name,
                           Options(target=target))
    return conversion, build


@cache
def example_places() -> dict[int, tuple[Path, str, int]]:
    """RS line of each transcribed example -> (C file, program kind, slot)."""
    places: dict[int, tuple[Path, str, int]] = {}
    for path in MANUAL_FILES:
        for match in MARKER.finditer(path.read_text(encoding="utf-8")):
            line = int(match.group(3))
            assert line not in places, f"RS {line} transcribed twice"
            places[line] = (path, "isr" if match.group(1) else "mp", int(match.group(2)))
    return places


def example_id(example: dict[str, Any]) -> str:
    return f"{example['section']}-RS{example['line']}"


# ------------------------------------------------------------------------------ the manual
def test_every_manual_example_has_a_c_transcription() -> None:
    assert {e["line"] for e in EXAMPLES} == set(example_places())


@pytest.mark.parametrize("path", MANUAL_FILES, ids=lambda p: p.name)
def test_manual_listings_import_completely_and_build(path: Path) -> None:
    conversion, build = imported(path)
    assert conversion.complete, conversion.warnings
    assert conversion.target == "rs"
    errors = [d.render() for d in build.diagnostics if d.severity.value == "error"]
    assert not errors, "\n".join(errors)


@pytest.mark.parametrize("example", EXAMPLES, ids=[example_id(e) for e in EXAMPLES])
def test_manual_example_imports_to_the_printed_frame(example: dict[str, Any]) -> None:
    path, kind, slot = example_places()[example["line"]]
    _, build = imported(path)
    (program,) = [p for p in build.programs
                  if (p.program.kind, p.placement.slot) == (kind, slot)]
    if example.get("kind") in ("close", "isr_close"):
        frame = program.close
    else:
        frame = program.lines[example.get("frame", 0)].frame
    assert frame == example["registers"], (
        f"RS {example['line']}: got {' '.join(f'{w:04X}' for w in frame)}, manual "
        f"{' '.join(f'{w:04X}' for w in example['registers'])}")


def test_manual_comments_stay_beside_their_statements() -> None:
    conversion, _ = imported(IMPORT / "manual_ch9.c")
    assert "# 9.1.3, RS 9951: printed as the real-time call RSM_MP_CALL" in conversion.text
    assert "    CALL MP21  # Execute the MP21 on i-8094H" in conversion.text
    assert "    VAR3 = VAR1 + VAR2\n    # VAR1 + VAR2 = VAR3" in conversion.text
    assert "    IF VAR1 <= VAR2\n    ELSE\n    END IF" in conversion.text
    assert "    GOTO 3\n    LABEL 3" in conversion.text


# ------------------------------------------------------------------------------ a whole program
WHOLE = IMPORT / "whole_program.c"
WHOLE_EXPECTED = """
MP 100
  SET_MAX_V XY, 8000
  NORMAL_SPEED XY, 0
  SET_V XY, 2000
  SET_A XY, 100000
  SET_SV XY, 100
  VAR10 = 0
  FOR 100
    SET_LP XY, 0
    CLEAR_SYNC_ACTION X
    SYNC_ACTION X, X, 1, 0, 0, 0, 0, 1, ISR1, 0, 0, 0
    ENABLE_INT
    SET_COMPARE X, 0, 0, 38000
    FIXED_MOVE X, 42000
    STOP_WAIT X
    VAR10 = VAR10 + 1
    TIMER 250
    IF VAR10 >= 50
      EXIT FOR
    END IF
    FIXED_MOVE Y, 500
  NEXT
END MP
ISR 1
  FRNET_OUT 0, 4
  VAR31 = GET_LP(X)
END ISR
"""


def line_of(path: Path, fragment: str) -> int:
    lines = path.read_text(encoding="utf-8").splitlines()
    (number,) = [n for n, text in enumerate(lines, 1) if fragment in text]
    return number


def test_whole_program_builds_to_what_a_person_would_write() -> None:
    _, build = imported(WHOLE)
    assert build.ok, [d.render() for d in build.diagnostics]
    expected = compile_source(WHOLE_EXPECTED, "expected.mp", Options(target="rs"))
    assert [p.frames for p in build.programs] == [p.frames for p in expected.programs]


def test_whole_program_names_what_it_cannot_convert() -> None:
    conversion, _ = imported(WHOLE)
    found = {(w.line, w.message.split(":")[0]) for w in conversion.warnings}
    assert found == {
        (line_of(WHOLE, "for (i = 0"), "cannot convert 'for (i = 0; i < 2; i++)'"),
        (line_of(WHOLE, "AXIS_Y, speed"), "cannot convert 'RSM_MACRO_FIXED_MOVE(hRsm, "
         "SlaveAddr, AXIS_Y, speed);'"),
        (line_of(WHOLE, "GET_HOME_STATE"), "cannot convert 'RSM_MACRO_GET_HOME_STATE(hRsm, "
         "SlaveAddr, AXIS_X);'"),
        (line_of(WHOLE, "RSM_SET_V("), "cannot convert 'RSM_SET_V(hRsm, SlaveAddr, AXIS_X, "
         "100);'"),
        # (the SYNC_ACTION call starts on the line before its arguments)
        (line_of(WHOLE, "0X00000040") - 1, "cannot convert 'RSM_MACRO_SYNC_ACTION(hRsm, "
         "SlaveAddr, AXIS_X, AXIS_X, 0X00000040, 6, 0, 0, 0, 0, 0, 0, 0);'"),
        (line_of(WHOLE, "RSM_MP_CALL("), "cannot convert 'RSM_MP_CALL(hRsm, SlaveAddr, "
         "MP100);'"),
    }
    messages = " | ".join(w.message for w in conversion.warnings)
    assert "did you mean RSM_MACRO_GET_HOME_SEARCH_STATE?" in messages
    assert "speed is not a constant" in messages
    assert "its macro form is RSM_MACRO_SET_V" in messages
    assert "takes 14 arguments" in messages and "got 13" in messages


def test_whole_program_keeps_comments_blank_lines_and_host_code() -> None:
    text = imported(WHOLE)[0].text
    assert "# glue_cell.c - downloads the glue cell's macro programs into an RS-M8194H." in text
    assert "CONST BEAD_LENGTH = 42000  # pulses" in text
    assert "CONST VALVE_AT = BEAD_LENGTH - 4000" in text
    assert "ALIAS BEADS = VAR10" in text and "CONST SETTLE_MS = 250" in text
    assert "# C: int main(void)" in text and "# C:     if (hRsm == NULL) {" in text
    assert "MP 100  # Create a macro program MP100." in text
    assert "    BEADS = 0  # beads laid so far\n\n    FOR 100" in text
    assert "        SET_COMPARE X, 0, 0, VALVE_AT" in text
    assert "        BEADS = BEADS + 1" in text and "        TIMER SETTLE_MS" in text
    assert "        # not converted: for (i = 0; i < 2; i++)" in text
    assert "    # not converted: RSM_MACRO_SYNC_ACTION(hRsm, SlaveAddr, AXIS_X, AXIS_X," in text
    assert "# not converted: RSM_MP_CALL(hRsm, SlaveAddr, MP100); // Execute the MP100" in text


def test_et_listing_converts_and_the_checks_find_the_manual_slips() -> None:
    path = IMPORT / "et_example5.c"
    conversion, build = imported(path, "et")
    assert conversion.complete and conversion.target == "et"
    (error,) = [d for d in build.diagnostics if d.severity.value == "error"]
    assert error.code == "E412"
    assert conversion.line_map[error.span.line - 1] == line_of(path, "AXIS_XY, 5000")
    fixed = convert(path.read_text().replace("AXIS_XY, 5000", "AXIS_XY, 8000"))
    build = compile_source(fixed.text, "fixed.mp", Options(target="et"))
    assert [d.code for d in build.diagnostics if d.severity.value == "error"] == ["E503"]


# ------------------------------------------------------------------------------ samples via C
def c_operand(param: Param, value: Operand) -> str:
    """How a C programmer writes a decoded operand against the vendor header."""
    profile = CAT.profile
    if isinstance(value, VarRef):
        return f"VAR{value.index}"
    if isinstance(value, BVarRef):
        return f"bVAR{value.index}"
    assert isinstance(value, int)
    if param.kind.startswith("axis") and value:
        return "AXIS_" + profile.axis_name(value)
    if param.kind in ("mp", "isr") or (param.kind == "isr_or_none" and value):
        return f"{param.kind.removesuffix('_or_none').upper()}{value}"
    if param.kind == "calc_op":
        return repr(chr(value))
    if param.kind == "cmp_op":
        return '"' + {v: k for k, v in profile.cmp_ops.items()}[value] + '"'
    return f"{value}L" if param.wire == 2 else str(value)


def samples_as_c(build: BuildResult) -> str:
    encoder = Encoder(CAT, build.word_order)
    out = ['#include "RSM8194H.h"', "void download(HANDLE hRsm)", "{"]
    for program in build.programs:
        kind, slot = program.program.kind, program.placement.slot
        create = "RSM_MP_CREATE" if kind == "mp" else "RSM_MP_ISR_CREATE"
        out.append(f"    {create}(hRsm, 1, {kind.upper()}{slot});")
        for line in program.lines:
            command, operands = encoder.decode(line.frame)
            args = ["hRsm", "1", *(c_operand(p, v) for p, v in zip(command.params, operands,
                                                                   strict=True))]
            out.append(f"    {command.name}({', '.join(args)});")
        close = "RSM_MACRO_MP_CLOSE" if kind == "mp" else "RSM_MACRO_MP_ISR_CLOSE"
        out.append(f"    {close}(hRsm, 1);\n")
    return "\n".join([*out, "}"])


def test_every_sample_line_survives_a_trip_through_c() -> None:
    build = compile_paths(sorted((DATA.parent.parent / "samples").glob("*.mp")))
    assert build.ok
    conversion = convert(samples_as_c(build))
    assert conversion.complete, conversion.warnings[:3]
    again = compile_source(conversion.text, "from_c.mp", Options(target="rs"))
    assert again.ok, [d.render() for d in again.diagnostics][:3]
    assert [p.frames for p in again.programs] == [p.frames for p in build.programs]


# ------------------------------------------------------------------------------ details
def body(text: str) -> list[str]:
    return [line.split("#")[0].strip() for line in text.splitlines()
            if line.split("#")[0].strip()]


def in_program(*calls: str, prefix: str = "") -> Conversion:
    lines = [prefix, "RSM_MP_CREATE(hRsm, 1, MP100);", *calls, "RSM_MACRO_MP_CLOSE(hRsm, 1);"]
    return convert("\n".join(lines) + "\n")


def test_numbers_follow_c() -> None:
    assert c_number("20000L").value == 20000
    assert (c_number("0x0000FFFFUL").value, c_number("0x0000FFFFUL").text) == (65535,
                                                                               "0x0000FFFF")
    assert c_number("010").value == 8  # octal
    assert c_number("0b101").value == 5
    assert isinstance(c_number("1.5").value, float)
    with pytest.raises(Unconvertible):
        c_number("09")


def test_argument_expressions_casts_and_names() -> None:
    result = in_program("RSM_MACRO_SET_V(hRsm, 1, AXIS_X | AXIS_Y, (long)2000 * 2);",
                        "RSM_MACRO_SET_HOME_MODE(hRsm, 1, (BYTE)0x1, 2, 2, 1, 1, 3500);",
                        "RSM_MACRO_IF(hRsm, 1, VAR1, LE, -7 / 2);",
                        "RSM_MACRO_END_IF(hRsm, 1);",
                        "ret = RSM_MACRO_FRNET_OUT(hRsm, 1, bVAR0, VAR1);",
                        "(void)RSM_MACRO_GOTO(hRsm, 1, LABEL2);",
                        "RSM_MACRO_LABEL(hRsm, 1, 2);",
                        "RSM_MACRO_MIX_2D_CONTINUE(hRsm, 1, 0, LINE_2D, 0, 0, 100, 100);")
    assert result.complete, result.warnings
    assert body(result.text)[1:] == [
        "SET_V XY, 2000 * 2", "SET_HOME_MODE X, 2, 2, 1, 1, 3500", "IF VAR1 <= -7 / 2",
        "END IF", "FRNET_OUT bVAR0, VAR1", "GOTO 2", "LABEL 2",
        "MIX_2D_CONTINUE 0, LINE_2D, 0, 0, 100, 100", "END MP"]
    build = compile_source(result.text, "t.mp")
    assert build.ok
    assert build.programs[0].lines[2].frame[4:] == [0xFFFF, 0xFFFD]  # C division: -3


def test_defines_and_constants() -> None:
    result = convert("#define SPEED 2000L  // PPS\n#define HALF (SPEED / 2)\n"
                     "#define REST (7 % 3)\n#define X 5\n#define SPEED 3000\n"
                     "#define WHERE MP21\nstatic const int COUNT = 4;\n"
                     "#define SQR(a) ((a) * (a))\n"
                     "RSM_MP_CREATE(hRsm, 1, WHERE);\n#define INSIDE 7\n"
                     "RSM_MACRO_FOR(hRsm, 1, COUNT);\n"
                     "RSM_MACRO_SET_V(hRsm, 1, AXIS_X, HALF + X + REST + INSIDE);\n"
                     "RSM_MACRO_NEXT(hRsm, 1);\nRSM_MACRO_MP_CLOSE(hRsm, 1);\n")
    assert result.complete, result.warnings
    lines = body(result.text)
    assert lines[:4] == ["CONST SPEED = 2000", "CONST HALF = SPEED / 2", "CONST REST = 1",
                         "CONST WHERE = 21"]
    assert "CONST COUNT = 4" in lines
    assert "# C: #define X 5" in result.text  # X is an axis name: the value is used instead
    assert "# C: #define SPEED 3000" in result.text  # a second definition is not taken
    assert "# C: #define SQR(a) ((a) * (a))" in result.text
    assert lines.index("CONST INSIDE = 7") < lines.index("MP 21")  # hoisted out of the MP
    assert "SET_V X, 1007" in lines or "SET_V X, 1000 + 5 + 1 + INSIDE" not in lines
    build = compile_source(result.text, "t.mp")
    assert build.ok, [d.render() for d in build.diagnostics]
    assert build.programs[0].lines[1].frame[2:] == [0, 1000 + 5 + 1 + 7]


def test_program_structure_problems_are_named() -> None:
    result = convert("RSM_MACRO_SET_V(hRsm, 1, AXIS_X, 100);\n"
                     "RSM_MP_ISR_CREATE(hRsm, 1, ISR2);\n"
                     "RSM_MP_CREATE(hRsm, 1, MP3);\n"
                     "RSM_MACRO_MP_CLOSE(hRsm, 1);\n"
                     "RSM_MACRO_FIXED_MOVE(hRsm, 1, AXIS_Y, 10);\n")
    messages = {w.line: w.message for w in result.warnings}
    assert "outside RSM_MP_CREATE" in messages[1]
    assert "while ISR2 is still open" in messages[3]
    assert "cannot close ISR2" in messages[4]
    assert "the file ends inside ISR2" in messages[6]
    assert body(result.text)[-2:] == ["FIXED_MOVE Y, 10", "END ISR"]
    assert compile_source(result.text, "t.mp").ok


def test_slot_from_a_c_variable_is_left_to_the_linker() -> None:
    result = convert("RSM_MP_CREATE(hRsm, 1, slot);\nRSM_MACRO_EXIT_MACRO(hRsm, 1);\n"
                     "RSM_MACRO_MP_CLOSE(hRsm, 1);\n")
    assert "left to the linker" in result.warnings[0].message
    assert body(result.text)[0] == "MP"
    assert compile_source(result.text, "t.mp").ok


def test_isr_number_must_be_an_isr() -> None:
    result = in_program("RSM_MACRO_INTFACTOR_ENABLE(hRsm, 1, AXIS_X, 4, MP1);")
    assert "MP1 is not an ISR number" in result.warnings[0].message


def test_statements_and_control_flow_inside_a_program() -> None:
    result = in_program("int i;", "if (x) {", "RSM_MACRO_STOP_WAIT(hRsm, 1, AXIS_X);", "}",
                        "else RSM_MACRO_EXIT_MACRO(hRsm, 1);", "while (RSM_MACRO_X(a)) ;",
                        "x = 1 + RSM_MACRO_GET_LP(hRsm, 1, AXIS_X);", "#ifdef FAST",
                        "#endif", "RSM_MACRO_TIMER(hRsm, 1, 1.5);",
                        "RSM_MACRO_TIMER(hRsm, 1, f(2));")
    whys = [w.message for w in result.warnings]
    assert len(whys) == 9, whys
    assert "C statement inside a macro program" in whys[0]
    assert "C if runs on the host" in whys[1] and "C else" in whys[2]
    assert "C while" in whys[3]
    assert "a vendor call inside a C expression" in whys[4]
    assert "preprocessor conditionals" in whys[5] and "preprocessor" in whys[6]
    assert "1.5 is not an integer" in whys[7] and "only known at run time" in whys[8]
    assert body(result.text)[1:3] == ["STOP_WAIT X", "EXIT"]


def test_tokenizer_edge_cases() -> None:
    result = convert('printf("// not a comment /* either */");\r\n'
                     "#define LONG_ONE \\\r\n   100\r\n"
                     "RSM_MP_CREATE(hRsm, 1, MP4); /* block\r\n * comment */\r\n"
                     "RSM_MACRO_TIMER(hRsm, 1, LONG_ONE);\r\n"
                     "RSM_MACRO_MP_CLOSE(hRsm, 1);\r\n/* never closed")
    assert result.complete, result.warnings
    assert '# C: printf("// not a comment /* either */");' in result.text
    assert "CONST LONG_ONE = 100" in result.text
    assert "MP 4  # block comment" in result.text
    assert "    TIMER LONG_ONE" in result.text
    assert result.text.rstrip().endswith("# never closed")
    assert result.line_map[result.text.splitlines().index("    TIMER LONG_ONE")] == 6


def test_block_comments_lose_their_decoration_only() -> None:
    result = convert("/*\n * Title\n *\n * body text\n */\n")
    assert result.text.splitlines()[2:] == ["# Title", "#", "# body text"]


c_fragments = st.sampled_from([
    "RSM_MP_CREATE(hRsm, 1, MP3);", "RSM_MACRO_SET_V(hRsm, 1, AXIS_X, 100);",
    "RSM_MACRO_MP_CLOSE(hRsm, 1);", "ETM_MP_ISR_CREATE(h, c, ISR1);", "RSM_MACRO_FOR(h,1,",
    "RSM_MACRO_IF(h, 1, VAR1, \"<\", 3);", "{", "}", "(", ")", ";", ",", "//", "/*", "*/",
    "\"", "'", "\n", " ", "#define A ", "#if 0", "if (x)", "else", "x = ", "1", "0x", "L",
    "VAR1", "AXIS_", "case 1:", "label:", "\\\n", "\r\n", "RSM_", "?", "@", "é"])


@settings(max_examples=150, deadline=None)
@given(st.lists(c_fragments, max_size=40).map("".join))
def test_any_c_text_converts_without_crashing(text: str) -> None:
    result = convert(text)
    total = text.count("\n") + 2
    assert all(1 <= w.line <= total for w in result.warnings)
    assert len(result.line_map) == len(result.text.splitlines())


@settings(max_examples=60, deadline=None)
@given(st.text(max_size=200))
def test_any_text_converts_without_crashing(text: str) -> None:
    """A conversion, with its warnings at lines of the text and a source line for each
    line written, never an exception."""
    result = convert(text)
    total = text.count("\n") + 2
    assert all(1 <= w.line <= total and w.message for w in result.warnings)
    # lines as the compiler splits them: at "\n" only (a NEL in a comment is no line end)
    assert result.text.endswith("\n")
    assert len(result.line_map) == result.text.count("\n")


def test_read_c_file_falls_back_for_chinese_comments() -> None:
    data = "// 設定速度\n".encode("cp950")
    text, used = read_c_file(data)
    assert used == "cp950" and "設定速度" in text
    assert read_c_file(b"x")[1] == "utf-8"


# ------------------------------------------------------------------------------ command line
def run(*args: str) -> tuple[int, str, str]:
    outcome = CliRunner().invoke(main, list(args))
    return outcome.exit_code, outcome.stdout, outcome.stderr


def test_cli_complete_conversion_exits_0(tmp_path: Path) -> None:
    out = tmp_path / "ch9.mp"
    code, stdout, stderr = run("import", str(IMPORT / "manual_ch9.c"), "-o", str(out))
    assert (code, stdout, stderr) == (0, "", "")
    assert compile_paths([out], Options(target="rs")).ok


def test_cli_omissions_exit_13_with_lines(tmp_path: Path) -> None:
    code, stdout, stderr = run("import", str(WHOLE))
    assert code == 13
    assert "MP 100" in stdout
    line = line_of(WHOLE, "for (i = 0")
    assert f"{WHOLE}:{line}: cannot convert 'for (i = 0; i < 2; i++)'" in stderr
    assert stderr.strip().endswith("mpc: error: 6 construct(s) not converted")


def test_cli_check_reports_at_the_c_line(tmp_path: Path) -> None:
    path = IMPORT / "et_example5.c"
    code, _, stderr = run("import", str(path), "--check")
    assert code == 1
    assert f"{path}:{line_of(path, 'AXIS_XY, 5000')}: error[E412]" in stderr


def test_cli_input_problems(tmp_path: Path) -> None:
    code, _, stderr = run("import", str(tmp_path / "none.c"))
    assert code == 3 and "cannot read" in stderr
    path = tmp_path / "big5.c"
    path.write_bytes("// 巨集\nRSM_MP_CREATE(h, 1, MP1);\nRSM_MACRO_MP_CLOSE(h, 1);\n"
                     .encode("cp950"))
    code, stdout, stderr = run("import", str(path))
    assert code == 0 and "# 巨集" in stdout and "read as cp950" in stderr
    code, _, stderr = run("import", str(path), "--encoding", "utf-8")
    assert code == 3 and "not utf-8 text" in stderr
    code, _, stderr = run("import", str(path), "--encoding", "klingon")
    assert code == 2 and "unknown encoding" in stderr


def fenced_after(text: str, marker: str) -> str:
    """The first fenced code block after `marker` in a docs page."""
    rest = text[text.index(marker):]
    start = rest.index("```")
    start = rest.index("\n", start) + 1
    return rest[start:rest.index("```", start)]


def test_the_docs_example_is_what_import_writes() -> None:
    page = (DATA.parent.parent / "docs" / "import.md").read_text(encoding="utf-8")
    source = fenced_after(page, "For this file:")
    result = convert(source, source_name="doc.c")
    assert result.text == fenced_after(page, "`mpc import doc.c -o doc.mp` writes:")
    reported = fenced_after(page, "and reports on standard error").splitlines()
    assert [f"doc.c:{w.line}: {w.message}" for w in result.warnings] == reported[:-1]
