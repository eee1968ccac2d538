"""`mpc disasm`: images back to source that rebuilds to the very same frames.

The round trip build(disasm(build(x))) == build(x) is checked for every sample (all together
and each alone), in both word orders, and for random programs; images another tool could have
written (unknown codes, real-time commands, operands the compiler refuses) must come out as
commented frames that are named, never lost silently.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mplang.cli import main
from mplang.ir import catalogue
from mplang.ir.macro import MacroLine, Operand
from mplang.lang.diagnostics import Span
from mplang.m8194h.compiler import BuildResult, Options, compile_paths, compile_source
from mplang.m8194h.disasm import Disassembly, disassemble
from mplang.m8194h.encode import Encoder
from mplang.m8194h.flash import FlashImage, image_from_build, image_from_json

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
CAT = catalogue.load()


def frames(build: BuildResult) -> list[tuple[str, int, list[list[int]]]]:
    return [(p.program.kind, p.placement.slot, p.frames) for p in build.programs]


def round_trip(build: BuildResult, temps: range = range(500, 512),
               strip_lines: bool = False) -> tuple[Disassembly, BuildResult]:
    """disasm(image of build), then build that text again with the same options."""
    assert build.ok, [d.render() for d in build.diagnostics]
    image = image_from_build(build)
    if strip_lines:
        for program in image.programs:
            program.lines = [None] * len(program.frames)
    result = disassemble(image, temps, variant=build.target)
    rebuilt = compile_source(result.text, "rebuilt.mp",
                             Options(word_order=build.word_order, target=build.target,
                                     temps=temps))
    errors = [d.render() for d in rebuilt.diagnostics if d.severity.value == "error"]
    assert not errors, "\n".join(errors) + "\n" + result.text
    return result, rebuilt


# ------------------------------------------------------------------------------ samples
@pytest.mark.parametrize("word_order", [0, 1])
def test_all_samples_together_round_trip(word_order: int) -> None:
    build = compile_paths(SAMPLES, Options(word_order=word_order))
    result, rebuilt = round_trip(build)
    assert result.exact, result.problems
    assert frames(rebuilt) == frames(build)


def _builds_alone(path: Path) -> bool:
    return compile_paths([path]).ok


@pytest.mark.parametrize("sample", [p for p in SAMPLES if _builds_alone(p)],
                         ids=lambda p: p.name)
@pytest.mark.parametrize("word_order", [0, 1])
def test_each_sample_alone_round_trips(sample: Path, word_order: int) -> None:
    build = compile_paths([sample], Options(word_order=word_order))
    result, rebuilt = round_trip(build)
    assert result.exact, result.problems
    assert frames(rebuilt) == frames(build)


def test_samples_round_trip_without_source_lines() -> None:
    """Images from tools that write no frame_lines: no merging by line, still exact."""
    build = compile_paths(SAMPLES)
    result, rebuilt = round_trip(build, strip_lines=True)
    assert result.exact, result.problems
    assert frames(rebuilt) == frames(build)
    assert "# line" not in result.text


def test_most_samples_build_alone() -> None:
    """Guard: the per-sample round trip must not silently test nothing."""
    assert sum(_builds_alone(p) for p in SAMPLES) >= len(SAMPLES) // 2


# ------------------------------------------------------------------------------ lifting
def disasm_source(source: str, **options: object) -> tuple[str, BuildResult]:
    build = compile_source(source, "t.mp", Options(**options))  # type: ignore[arg-type]
    result, rebuilt = round_trip(build, temps=build_temps(options))
    assert result.exact, result.problems
    assert frames(rebuilt) == frames(build)
    return result.text, build


def build_temps(options: dict[str, object]) -> range:
    temps = options.get("temps", range(500, 512))
    assert isinstance(temps, range)
    return temps


def body(text: str) -> list[str]:
    """The statements of the output without comments, stripped."""
    out = []
    for line in text.splitlines():
        code = line.split("#", 1)[0].strip()
        if code:
            out.append(code)
    return out


def test_expressions_through_temporaries_become_one_statement() -> None:
    text, build = disasm_source("MP 100 calc\n VAR1 = (VAR2 + 3) * VAR4 - VAR5 / 2\n"
                                " VAR6 = VAR7 * (VAR8 - VAR9)\n VAR3 = VAR3 - (VAR3 - 1)\n"
                                "END MP\n")
    assert len(build.programs[0].lines) > 5  # several VAR_CALCULATE lines per statement
    assert body(text) == ["MP 100 calc", "VAR1 = (VAR2 + 3) * VAR4 - VAR5 / 2",
                          "VAR6 = VAR7 * (VAR8 - VAR9)", "VAR3 = VAR3 - (VAR3 - 1)", "END MP"]
    assert "VAR50" not in text  # no temporary left in sight


def test_queries_conditions_and_loops_through_temporaries() -> None:
    text, _ = disasm_source("MP 100\n VAR5 = GET_LP(X) + 100\n VAR6 = 7 - GET_EP(Y)\n"
                            " IF VAR1 + 1 > VAR2 * 2\n  FOR VAR3 - 1\n   EXIT FOR\n  NEXT\n"
                            " ELSE\n  VAR9 = GET_ERROR\n END IF\nEND MP\n")
    assert body(text) == ["MP 100", "VAR5 = GET_LP(X) + 100", "VAR6 = 7 - GET_EP(Y)",
                          "IF VAR1 + 1 > VAR2 * 2", "FOR VAR3 - 1", "EXIT FOR", "NEXT", "ELSE",
                          "VAR9 = GET_ERROR", "END IF", "END MP"]


def test_blocks_are_indented_and_labels_named_in_order() -> None:
    text, _ = disasm_source("MP 100\nLABEL top\n FOR 3\n  IF VAR1 == 0\n   GOTO done\n"
                            "  END IF\n NEXT\n GOTO top\nLABEL done\n EXIT\nEND MP\n")
    lines = [line.split("#")[0].rstrip() for line in text.splitlines()]
    assert "LABEL L0" in lines and "LABEL L1" in lines  # at the program's edge, as mpc fmt
    assert "            GOTO L1" in lines  # inside FOR and IF: three levels deep


def test_labels_keep_numbers_when_names_would_renumber_them() -> None:
    text, _ = disasm_source("MP 100\nLABEL 2\n GOTO 0\nLABEL 0\n GOTO 2\nEND MP\n")
    assert body(text)[1:5] == ["LABEL 2", "GOTO 0", "LABEL 0", "GOTO 2"]


def test_calls_and_isr_operands_use_program_names() -> None:
    text, _ = disasm_source("MP 5 helper\n EXIT\nEND MP\nISR 3 on_compare\n FIXED_MOVE Y, 1000\n"
                            "END ISR\nMP 41 main\n CALL helper\n CALL MP7\n"
                            " INTFACTOR_ENABLE X, 4, on_compare\nEND MP\n")
    assert "CALL helper" in body(text) and "CALL MP7" in body(text)
    assert "INTFACTOR_ENABLE X, 4, on_compare" in body(text)


def test_constant_calculations_stay_raw_and_symbols_are_named() -> None:
    text, _ = disasm_source("MP 100\n VAR_CALCULATE 5, '+', 3, VAR1\n VAR2 = -5\n VAR3 = -VAR2\n"
                            " IF 3 < 5\n END IF\n SET_RVAR VAR4\n"
                            " MIX_2D_CONTINUE 0, 1, 0, 0, 100, 100\nEND MP\n")
    assert body(text)[1:8] == ["VAR_CALCULATE 5, '+', 3, VAR1", "VAR2 = -5",
                               "VAR3 = 0 - VAR2", "IF 3 < 5", "END IF", "SET_RVAR VAR4",
                               "MIX_2D_CONTINUE 0, LINE_2D, 0, 0, 100, 100"]


def test_source_lines_are_given_in_comments() -> None:
    text, _ = disasm_source("# comment\nMP 21 square\n  SET_V X, 2000\n\n  FIXED_MOVE X, 1000\n"
                            "END MP\n")
    assert "MP 21 square" in text and "# from t.mp:2" in text
    assert "SET_V X, 2000" in text and "# line 3" in text
    assert "\n\n    FIXED_MOVE X, 1000" in text  # the gap in the source stays a gap


def test_other_temporary_pool() -> None:
    source = "MP 100\n VAR1 = (VAR2 + 3) * (VAR4 - 1)\nEND MP\n"
    text, _ = disasm_source(source, temps=range(400, 412))
    assert body(text)[1] == "VAR1 = (VAR2 + 3) * (VAR4 - 1)"
    # disassembled with the default pool, the 400s are ordinary variables: exact anyway
    build = compile_source(source, "t.mp", Options(temps=range(400, 412)))
    result, rebuilt = round_trip(build)
    assert result.exact and frames(rebuilt) == frames(build)
    assert "VAR400" in result.text


def test_user_code_in_the_pool_is_exact_and_silenced() -> None:
    source = ("MP 100\n VAR500 = 5   # mpc: ignore[W104]\n VAR1 = VAR500 * 2  # mpc: ignore\n"
              "END MP\n")
    build = compile_source(source, "t.mp")
    result, rebuilt = round_trip(build)
    assert result.exact and frames(rebuilt) == frames(build)
    assert not [d for d in rebuilt.diagnostics if d.code == "W104"]


def test_rs_only_commands_keep_the_rs_target() -> None:
    text, _ = disasm_source("MP 3\n INTP_END 0\nEND MP\n", target="rs")
    assert "--target rs" in text


# ------------------------------------------------------------------------------ random programs
VARS = [1, 2, 3, 7]
leaf = st.one_of(st.integers(-30, 30).map(str), st.sampled_from([f"VAR{v}" for v in VARS]),
                 st.sampled_from(["GET_LP(X)", "GET_ERROR"]))
expressions = st.recursive(leaf, lambda inner: st.tuples(inner, st.sampled_from("+-*/&|"),
                                                         inner).map(
    lambda t: f"({t[0]} {t[1]} {t[2]})"), max_leaves=5)
commands = st.sampled_from(["SET_V X, 2000", "FIXED_MOVE XY, -3000", "STOP_WAIT X",
                            "TIMER VAR2", "FRNET_OUT 0, VAR3", "SET_RVAR VAR7", "GET_LP Y",
                            "CALL MP7", "CALL other", "EXIT", "VAR_CALCULATE 1, '*', 2, VAR3"])


def flat(groups: list[list[str]]) -> list[str]:
    return [line for group in groups for line in group]


def statements(depth: int) -> st.SearchStrategy[list[str]]:
    simple = st.one_of(
        st.builds(lambda v, e: [f"VAR{v} = {e}"], st.sampled_from(VARS), expressions),
        commands.map(lambda c: [c]),
    )
    if depth == 0:
        return st.lists(simple, min_size=1, max_size=3).map(flat)
    inner = statements(depth - 1)
    block = st.one_of(
        simple,
        st.builds(lambda a, op, b, then, other: [f"IF {a} {op} {b}", *then,
                                                 *(["ELSE", *other] if other else []),
                                                 "END IF"],
                  expressions, st.sampled_from(["<", ">", "<=", ">=", "==", "!="]),
                  expressions, inner, st.one_of(st.none(), inner)),
        st.builds(lambda count, loop: [f"FOR {count}", *loop, "NEXT"],
                  st.one_of(st.integers(0, 5).map(str), expressions), inner),
    )
    return st.lists(block, min_size=1, max_size=3).map(flat)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(statements(2), st.sampled_from([0, 1]), st.booleans(), st.booleans())
def test_random_programs_round_trip(lines: list[str], word_order: int, label: bool,
                                    strip: bool) -> None:
    text = "\n".join(lines)
    if label:
        text = "LABEL again\n" + text + "\nGOTO again"
    source = f"MP 7 other\n EXIT\nEND MP\nMP 156\n{text}\nEND MP\n"
    build = compile_source(source, "random.mp", Options(word_order=word_order))
    assume(build.ok)  # constants beyond the device range, too many temporaries, ...
    result, rebuilt = round_trip(build, strip_lines=strip)
    assert result.exact, result.problems
    assert frames(rebuilt) == frames(build)


# ------------------------------------------------------------------------------ foreign images
def image_with(*body_frames: list[int], word_order: int = 0, kind: str = "mp",
               slot: int = 156) -> FlashImage:
    encoder = Encoder(CAT, word_order)
    program_frames = [encoder.create_frame(kind, slot), *body_frames, encoder.close_frame(kind)]
    data = {"format": "mplang-image/1", "target": {"word_order": word_order},
            "programs": [{"kind": kind, "slot": slot, "frames": program_frames}]}
    return image_from_json(data, "foreign.json", CAT)


def frame_of(name: str, *operands: Operand, word_order: int = 0) -> list[int]:
    command = CAT.lookup(name)
    assert command is not None
    return Encoder(CAT, word_order).frame(MacroLine(command, operands, Span("x", 1)))


def test_unknown_codes_and_real_time_commands_are_named_and_commented() -> None:
    move = frame_of("FIXED_MOVE", 1, 1000)
    rtc = frame_of("RSM_SET_V", 1, 2000)  # a real-time code inside a program
    image = image_with(move, [0x0BAD, 1], rtc, move)
    result = disassemble(image)
    assert not result.exact
    assert any("frame 2 (0BAD 0001)" in p and "unknown sub-function code" in p
               for p in result.problems)
    assert any("frame 3" in p and "E401" in p for p in result.problems)
    assert "# frame 2: 0BAD 0001" in result.text
    rebuilt = compile_source(result.text, "r.mp")
    assert rebuilt.ok
    assert rebuilt.programs[0].frames == [image.programs[0].frames[i] for i in (0, 1, 4, 5)]


def test_operands_the_compiler_refuses_become_comments() -> None:
    bad_if = [0x0CD7, 0x7FFF, 1, 0x3C3D, 0, 5]  # '<=' in the byte order of the RS 10577 print
    huge = [0x0CD2, 0x7FFF, 2, 0x7FFF, 0xFFFF]  # VAR2 = VAR65535: no such variable
    result = disassemble(image_with(bad_if, frame_of("END_IF"), huge))
    assert len(result.problems) >= 2
    assert all(p.startswith("MP156: frame") for p in result.problems)


def test_unbalanced_blocks_are_reported_not_hidden() -> None:
    result = disassemble(image_with(frame_of("FOR", 3), frame_of("STOP_WAIT", 1)))
    assert not result.exact
    assert "FOR 3" not in [line.split("#")[0].strip() for line in result.text.splitlines()]


def test_unusable_program_names_are_dropped_with_a_note() -> None:
    data = {"format": "mplang-image/1", "target": {"word_order": 0},
            "programs": [{"kind": "mp", "slot": 3, "name": "FIXED_MOVE",
                          "frames": [[0x0AC9, 3], [0x0CCA]]},
                         {"kind": "mp", "slot": 4, "name": "not a name",
                          "frames": [[0x0AC9, 4], [0x0CCB, 3], [0x0CCA]]}]}
    result = disassemble(image_from_json(data, "x.json", CAT))
    assert result.exact, result.problems
    assert "MP 3  " in result.text and "image name 'FIXED_MOVE' is not usable" in result.text
    assert "CALL MP3" in result.text


macro_commands = [c for c in CAT.commands if c.code is not None and c.is_macro
                  and c.short_name not in ("MP_CLOSE", "MP_ISR_CLOSE")]


@st.composite
def random_frames(draw: st.DrawFn) -> list[list[int]]:
    """Decodable frames with arbitrary operand words, and some undecodable ones."""
    out = []
    for _ in range(draw(st.integers(1, 8))):
        command = draw(st.sampled_from(macro_commands))
        words = [draw(st.integers(0, 0xFFFF)) for _ in range(command.registers - 1)]
        out.append(draw(st.sampled_from([[command.code, *words], [0x0C00 + len(words)]])))
    return out


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_frames(), st.sampled_from([0, 1]))
def test_any_image_disassembles_and_everything_not_exact_is_named(
        body_frames: list[list[int]], word_order: int) -> None:
    image = image_with(*body_frames, word_order=word_order)
    result = disassemble(image)
    target = "rs" if "--target rs" in result.text else "et"
    rebuilt = compile_source(result.text, "r.mp", Options(word_order=word_order, target=target))
    if result.exact:
        assert rebuilt.ok and rebuilt.programs[0].frames == image.programs[0].frames
    else:
        assert result.problems and all(isinstance(p, str) and p for p in result.problems)


# ------------------------------------------------------------------------------ command line
def run(*args: str) -> tuple[int, str, str]:
    outcome = CliRunner().invoke(main, list(args))
    return outcome.exit_code, outcome.stdout, outcome.stderr


def write_image(tmp_path: Path, build: BuildResult) -> Path:
    path = tmp_path / "image.json"
    path.write_text(json.dumps(build.image()))
    return path


def test_cli_writes_source_that_builds_to_the_same_image(tmp_path: Path) -> None:
    build = compile_paths(SAMPLES, Options(word_order=1))
    image = write_image(tmp_path, build)
    out = tmp_path / "back.mp"
    code, stdout, stderr = run("disasm", str(image), "-o", str(out))
    assert (code, stdout, stderr) == (0, "", "")
    assert "--word-order 1" in out.read_text()
    again = compile_paths([out], Options(word_order=1))
    assert again.ok and frames(again) == frames(build)
    code, stdout, _ = run("disasm", str(image))
    assert code == 0 and stdout == out.read_text()


@pytest.mark.parametrize("content, expected", [
    ("{nope", "image.json:1:2: not JSON"),
    ('{"format": "mplang-image/1", "target": {"word_order": 0}, "programs": '
     '[{"kind": "mp", "slot": 3, "frames": [[2761, 4], [3274]]}]}',
     "image.json: programs[0].frames[0]: must be the create frame"),
    ('{"format": "other"}', "image.json: format: expected"),
])
def test_cli_bad_images_exit_3_with_the_place(tmp_path: Path, content: str,
                                              expected: str) -> None:
    path = tmp_path / "image.json"
    path.write_text(content)
    code, stdout, stderr = run("disasm", str(path))
    assert code == 3 and stdout == ""
    assert expected in stderr and "Traceback" not in stderr


def test_cli_missing_image_exits_3(tmp_path: Path) -> None:
    code, _, stderr = run("disasm", str(tmp_path / "none.json"))
    assert code == 3 and "cannot read" in stderr


def test_cli_not_exact_exits_14_and_names_frames(tmp_path: Path) -> None:
    image = image_with(frame_of("FIXED_MOVE", 1, 1000), [0x0BAD])
    data = {"format": "mplang-image/1", "target": {"word_order": 0},
            "programs": [{"kind": "mp", "slot": 156, "frames": image.programs[0].frames}]}
    path = tmp_path / "foreign.json"
    path.write_text(json.dumps(data))
    code, stdout, stderr = run("disasm", str(path))
    assert code == 14
    assert "FIXED_MOVE X, 1000" in stdout
    assert f"{path}: warning: MP156: frame 2 (0BAD)" in stderr


def test_cli_unwritable_output_exits_4(tmp_path: Path) -> None:
    image = write_image(tmp_path, compile_source("MP 1\nEND MP\n"))
    code, _, stderr = run("disasm", str(image), "-o", str(tmp_path / "no" / "out.mp"))
    assert code == 4 and "cannot write" in stderr


def test_programs_keep_slot_and_kind() -> None:
    """Auto-placed programs get their slot written out, ISRs stay ISRs."""
    build = compile_source("ISR 19 big\n FIXED_MOVE Y, 1000\nEND ISR\nMP auto\n EXIT\nEND MP\n")
    result, rebuilt = round_trip(build)
    assert "ISR 19 big" in result.text and "MP 1 auto" in result.text
    assert frames(rebuilt) == frames(build)


def fenced_after(text: str, marker: str) -> str:
    """The first fenced code block after `marker` in a docs page."""
    rest = text[text.index(marker):]
    start = rest.index("```")
    start = rest.index("\n", start) + 1
    return rest[start:rest.index("```", start)]


def test_the_docs_example_is_what_disasm_writes() -> None:
    page = (ROOT / "docs" / "disasm.md").read_text(encoding="utf-8")
    source = fenced_after(page, "For this source:")
    expected = fenced_after(page, "`mpc disasm` of its image writes:")
    build = compile_source(source, "job.mp")
    result = disassemble(image_from_build(build), origin="job.json", variant="et")
    assert result.exact and result.text == expected


# ------------------------------------------------------------- configuration blocks
@pytest.mark.parametrize("word_order", [0, 1])
def test_init_and_trigger_table_round_trip(word_order: int) -> None:
    build = compile_paths([ROOT / "samples" / "controller" / "controller.mp"],
                          Options(word_order=word_order))
    result, rebuilt = round_trip(build)
    assert result.exact, result.problems
    assert "INIT\n" in result.text and "TRIGGERS\n" in result.text
    assert frames(rebuilt) == frames(build)
    assert build.init is not None and rebuilt.init is not None
    assert rebuilt.init.frames == build.init.frames
    assert build.triggers is not None and rebuilt.triggers is not None
    strip = [{k: v for k, v in e.items() if k != "line"} for e in build.triggers.entries]
    assert [{k: v for k, v in e.items() if k != "line"} for e in rebuilt.triggers.entries] \
        == strip


def test_an_init_frame_that_cannot_be_decoded_is_named() -> None:
    build = compile_source("INIT\n    SERVO_ON X\nEND INIT\nMP 1\n    VAR1 = 1\nEND MP\n")
    image = image_from_build(build)
    assert image.init is not None
    image.init.frames[0] = [0x0A15]  # SERVO_ON without its axis register
    result = disassemble(image)
    assert not result.exact
    assert any(p.startswith("INIT: frame 0") for p in result.problems)
