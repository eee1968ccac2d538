"""Hostile input: one regression test per finding of issue 19 (item 5, internal errors where a
diagnostic is documented) and issue 13 (item 9, constant folding and E424).

Each test goes through `mpc` as a user would (click's CliRunner) and checks the exit code,
the diagnostic's code and place, and that nothing says "internal error".
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang import m8194h
from mplang.cli import main
from mplang.ir.unit import Options
from mplang.lang.limits import MAX_BLOCK_DEPTH, MAX_EXPRESSION_DEPTH, load_json

ROOT = Path(__file__).resolve().parents[1]
CHECKS = ROOT / "tests" / "data" / "checks"
INTERNAL = 70


def mpc(*args: str | Path) -> tuple[int, str, str]:
    """Exit code, standard output, and what the user reads of diagnostics: standard error
    (and standard output for `mpc lint`, which reports there)."""
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code != INTERNAL and "internal error" not in result.stderr, \
        result.stderr
    assert "Traceback" not in result.stderr
    shown = result.stderr + (result.stdout if args and args[0] == "lint" else "")
    return result.exit_code, result.stdout, shown


def codes(stderr: str) -> list[tuple[str, int]]:
    """(code, line) of every diagnostic on standard error, in order."""
    return [(m.group(2), int(m.group(1)))
            for m in re.finditer(r":(\d+):\d+: (?:error|warning)\[([EW]\d{3})\]", stderr)]


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------- integer literals over 4,300 digits

HUGE = "9" * 5000


@pytest.mark.parametrize("command", [["build"], ["lint"], ["run"], ["fmt", "--check"],
                                     ["build", "--target", "csim"],
                                     ["build", "--target", "fbs-fun140"]])
def test_huge_literal_is_E108_in_every_command(tmp_path: Path, command: list[str]) -> None:
    source = write(tmp_path, "big.mp", f"MP 1 big\n    VAR1 = 1\n    VAR2 = {HUGE}\nEND MP\n")
    code, _, err = mpc(*command, source)
    assert code == 1
    assert "big.mp:3:12: error[E108]" in err and "5000 significant digits" in err


def test_huge_hex_literal_is_E108(tmp_path: Path) -> None:
    source = write(tmp_path, "hex.mp", f"MP 1 big\n    VAR2 = 0x{'F' * 5000}\nEND MP\n")
    code, _, err = mpc("build", source)
    assert code == 1 and codes(err) == [("E108", 2)]


@pytest.mark.parametrize("name, text, line", [
    ("big.fbs", f"TABLE t FUN140 Ps0\n001 SPD 5000\n002 DRV ADR,+,{HUGE},Ps\n", 3),
    ("big.csim", f"N0=1\nN1={HUGE}\n", 2),
])
def test_huge_literal_in_native_listing_is_E108(tmp_path: Path, name: str, text: str,
                                                line: int) -> None:
    for command in ("build", "lint", "run"):
        code, _, err = mpc(command, write(tmp_path, name, text))
        assert code == 1 and ("E108", line) in codes(err), err


# --------------------------------------------------- --target csim with unbalanced IF/ELSE

def test_csim_refused_raw_if_with_else_is_one_E424(tmp_path: Path) -> None:
    """The CSIM compiler met ELSE and END_IF without their IF (IndexError, two places)."""
    source = write(tmp_path, "if.mp", "MP 1 a\n    VAR1 = 1\n    RSM_MACRO_IF VAR1, 0x99, 1\n"
                   "    VAR1 = 2\n    ELSE\n    VAR1 = 3\n    END_IF\nEND MP\n")
    for target in ("et", "csim", "fbs-fun140"):
        code, _, err = mpc("build", "--target", target, source)
        assert code == 1 and codes(err) == [("E424", 3)], err


def test_csim_if_with_unknown_operand_keeps_blocks_balanced(tmp_path: Path) -> None:
    source = write(tmp_path, "if.mp", "MP 1 a\n    IF nowhere == 1\n        VAR1 = 2\n"
                   "    ELSE\n        VAR1 = 3\n    END IF\n    FOR nowhere\n        EXIT FOR\n"
                   "    NEXT\nEND MP\n")
    code, _, err = mpc("build", "--target", "csim", source)
    assert code == 1 and codes(err) == [("E202", 2), ("E202", 7)], err


# ------------------------------------------------ 1,000-term expressions, 1,000-deep blocks

def test_var_declaration_and_1000_term_expression_is_E107(tmp_path: Path) -> None:
    terms = "+".join(["speed"] * 1000)
    source = write(tmp_path, "long.mp", f"VAR speed\nMP 1 a\n    speed = 1\n"
                   f"    VAR2 = {terms}\nEND MP\n")
    for command in (["build"], ["lint"], ["run"], ["fmt", "--check"],
                    ["build", "--target", "csim"], ["build", "--target", "fbs-fun140"]):
        code, _, err = mpc(*command, source)
        assert code == 1 and codes(err) == [("E107", 4)], (command, err)


def test_expression_at_the_depth_bound_compiles(tmp_path: Path) -> None:
    terms = "+".join(["VAR1"] * MAX_EXPRESSION_DEPTH)  # depth: one leaf below the last +
    source = write(tmp_path, "ok.mp", f"MP 151 a\n    VAR1 = 1\n    VAR2 = {terms}\nEND MP\n")
    code, _, err = mpc("build", "--format", "listing", source)
    assert code == 0, err


@pytest.mark.parametrize("opener, closer, code", [("IF VAR1 == 1", "END IF", "E310"),
                                                  ("FOR 2", "NEXT", "E311"),
                                                  ("WHILE VAR1 < 1", "END WHILE", "E310")])
def test_blocks_nested_1000_deep(tmp_path: Path, opener: str, closer: str,
                                 code: str) -> None:
    text = ("MP 1 a\nVAR1 = 1\n" + f"{opener}\n" * 1000 + "VAR1 = 2\n" + f"{closer}\n" * 1000
            + "END MP\n")
    source = write(tmp_path, "deep.mp", text)
    for target in ("et", "csim", "fbs-fun140"):
        _, _, err = mpc("build", "--target", target, source)
        found = [c for c in codes(err) if c[0] == code]
        # the compiler's bound, once, where the nesting passes it (line 2 + depth)
        assert (code, 2 + MAX_BLOCK_DEPTH + 1) in found, err
        if opener.startswith("IF"):  # the device's limit, once
            assert found == [("E310", 2 + 8), ("E310", 2 + MAX_BLOCK_DEPTH + 1)], err
    code_fmt, _, err = mpc("fmt", "--check", source)
    assert code_fmt in (0, 12), err


def test_E310_of_the_device_limit_is_reported_once_per_nest(tmp_path: Path) -> None:
    text = "MP 156 a\nVAR1 = 1\n" + "IF VAR1 == 1\n" * 12 + "END IF\n" * 12 + "END MP\n"
    _, _, err = mpc("build", write(tmp_path, "d.mp", text))
    assert codes(err) == [("E310", 10)]


# --------------------------------------------------------- mpc fmt of the E107 example

def test_fmt_of_the_E107_example_reports_E107_and_leaves_it(tmp_path: Path) -> None:
    copy = write(tmp_path, "E107.mp", (CHECKS / "E107.mp").read_text())
    before = copy.read_bytes()
    code, _, err = mpc("fmt", copy)
    assert code == 1 and codes(err) == [("E107", 5)]
    assert copy.read_bytes() == before


# ---------------------------------------------------------------- mpc.toml globs, names

def project(tmp_path: Path, sources: str) -> Path:
    (tmp_path / "a.mp").write_text("MP 1 a\n    VAR1 = 1\nEND MP\n")
    return write(tmp_path, "mpc.toml", f"[project]\n# sources below\nsources = {sources}\n")


def test_absolute_glob_in_mpc_toml_sources(tmp_path: Path) -> None:
    toml = project(tmp_path, json.dumps(str(tmp_path / "*.mp")))
    code, _, err = mpc("lint", "--project", toml)
    assert code == 0, err


@pytest.mark.parametrize("sources, why", [
    (json.dumps("a" * 300), "File name too long"),
    ('"a**b/*.mp"', "'**' can only be an entire path component"),
    ('"x\\u0000y"', "NUL"),
    (json.dumps("/nonexistent-mplang/*.mp"), "no files match"),
    (f"{'9' * 5000}", "a number of 5000 digits"),
])
def test_bad_names_in_mpc_toml_sources_name_the_line(tmp_path: Path, sources: str,
                                                     why: str) -> None:
    toml = project(tmp_path, sources)
    code, _, err = mpc("build", "--project", toml)
    assert code == 3 and f"{toml}:3:" in err and why in err, err


# --------------------------------------------------------------- a 300-character file name

@pytest.mark.parametrize("command", [["build"], ["lint"], ["run"], ["fmt"], ["disasm"],
                                     ["flash", "--dry-run"]])
def test_300_character_file_name(tmp_path: Path, command: list[str]) -> None:
    code, _, err = mpc(*command, tmp_path / ("a" * 300 + ".mp"))
    assert code == 3 and "too long" in err, err


# ---------------------------------------------------------- deeply nested image JSON

@pytest.fixture
def image(tmp_path: Path) -> str:
    build = m8194h.compile_mp([ROOT / "samples" / "tour.mp"], Options(), "et")
    return build.render("json")


@pytest.mark.parametrize("command", [["disasm"], ["flash", "--dry-run"]])
def test_deeply_nested_image_json(tmp_path: Path, image: str, command: list[str]) -> None:
    cut = image.rindex("}")
    deep = write(tmp_path, "deep.json", f'{image[:cut]}, "x": {"[" * 5000}{"]" * 5000}}}')
    code, _, err = mpc(*command, deep)
    assert code == 3 and "nested more than 32 deep" in err, err
    huge = write(tmp_path, "huge.json", image.replace('"word_order": 0',
                                                      f'"word_order": {HUGE}'))
    code, _, err = mpc(*command, huge)
    assert code == 3 and "not an image" in err, err


def test_load_json_ignores_brackets_in_strings() -> None:
    assert load_json('{"a": "' + "[" * 100 + '", "b": [[1]]}') == {"a": "[" * 100,
                                                                   "b": [[1]]}
    with pytest.raises(ValueError, match="nested more than 2 deep"):
        load_json("[[[1]]]", max_depth=2)


# ------------------------------------------------- constant folding wraps as the device does

def test_constant_overflow_wraps_like_var_calculate(tmp_path: Path) -> None:
    """docs/language.md: 32-bit wrap-around, in folding exactly as on the controller
    (RS VAR_CALCULATE). The folded VAR2 and the device-computed VAR3 agree."""
    source = write(tmp_path, "wrap.mp", "MP 1 a\n    VAR1 = 2000000000\n"
                   "    VAR2 = 2000000000 + 2000000000\n    VAR3 = VAR1 + VAR1\nEND MP\n")
    code, _, err = mpc("build", source)
    assert code == 0 and codes(err) == [("W110", 3)] and "-294967296" in err
    assert mpc("build", "--werror", source)[0] == 1
    build = m8194h.compile_mp([source], Options(), "et")
    run = m8194h.run_build(build, None, 1.0)
    assert run.finished
    assert run.controller.vars[2] == run.controller.vars[3] == -294967296


def test_no_E308_after_E424(tmp_path: Path) -> None:
    source = write(tmp_path, "op.mp", "MP 1 a\n    VAR1 = 1\n    RSM_MACRO_IF VAR1, 3, 1\n"
                   "        VAR1 = 2\n    END IF\nEND MP\n")
    code, _, err = mpc("build", source)
    assert code == 1 and codes(err) == [("E424", 3)], err


@pytest.mark.parametrize("operator", ["0x3D3D", "EQ", '"=="', "OPERATOR"])
def test_raw_if_takes_any_spelling_of_a_comparison(tmp_path: Path, operator: str) -> None:
    """RS 10535-10562: the IF operator is a code; LE/EQ/... name them. Written raw, each
    spelling opens its block as `IF VAR1 == 1` does and encodes the same frame."""
    raw = write(tmp_path, "raw.mp", "CONST OPERATOR = 0x3D3D\nMP 1 a\n    VAR1 = 1\n"
                f"    RSM_MACRO_IF VAR1, {operator}, 1\n        VAR1 = 2\n    END IF\nEND MP\n")
    plain = write(tmp_path, "plain.mp", "CONST OPERATOR = 0x3D3D\nMP 1 a\n    VAR1 = 1\n"
                  "    IF VAR1 == 1\n        VAR1 = 2\n    END IF\nEND MP\n")
    frames = []
    for source in (raw, plain):
        build = m8194h.compile_mp([source], Options(), "et")
        assert build.ok, [d.render() for d in build.diagnostics]
        frames.append([line.frame for line in build.programs[0].lines])
    assert frames[0] == frames[1]


def test_const_chain_out_of_order_is_bounded(tmp_path: Path) -> None:
    """3,000 CONSTs each defined through the next one down: folded recursively, they were a
    RecursionError per CONST (thousands of E107, quadratic time); now an E107 wherever the
    chain passes the bound, and in order they are fine at any length."""
    backwards = "\n".join(f"CONST C{i} = C{i - 1} + 1" for i in range(2999, 0, -1))
    source = write(tmp_path, "chain.mp", f"{backwards}\nCONST C0 = 1\nMP 1 a\n"
                   "    VAR1 = C2999\nEND MP\n")
    code, _, err = mpc("build", source)
    found = codes(err)
    assert code == 1 and found and {c for c, _ in found} == {"E107"} and len(found) < 50
    forwards = "\n".join(f"CONST C{i} = C{i - 1} + 1" for i in range(1, 3000))
    source = write(tmp_path, "chain.mp", f"CONST C0 = 1\n{forwards}\nMP 1 a\n"
                   "    VAR1 = C2999\nEND MP\n")
    assert mpc("build", source)[0] == 0


def test_fmt_of_a_thousand_signs(tmp_path: Path) -> None:
    """`- - - ... 5` folds to one number for the compiler, but nests a tree level per sign
    for the formatter, which now follows the run without recursion."""
    source = write(tmp_path, "signs.mp", "MP 1 a\n    VAR1 = " + "- " * 1000 + "5\n"
                   "    VAR2 = " + "+" * 1000 + "VAR1\nEND MP\n")
    assert mpc("build", source)[0] == 0
    code, _, err = mpc("fmt", source)
    assert code == 0, err
    assert "VAR1 = " + "-" * 1000 + "5\n" in source.read_text()


def test_deeply_nested_flash_record_starts_afresh(tmp_path: Path) -> None:
    """The flash record (docs/flash.md): one that cannot be read is replaced, with a note;
    nested a thousand deep it was a RecursionError."""
    from mplang.m8194h.flash.record import FlashRecord

    path = write(tmp_path, "record.json", '{"a":' * 5000 + "1" + "}" * 5000)
    record = FlashRecord(path)
    assert record.devices == {} and record.problem is not None
    assert "nested more than 32 deep" in record.problem
    write(tmp_path, "a.mp", "MP 1 a\n    VAR1 = 1\nEND MP\n")
    code, _, err = mpc("flash", "--dry-run", "--project",
                       write(tmp_path, "mpc.toml", '[project]\nsources = ["a.mp"]\n'
                             '[flash]\nrecord = "record.json"\n'))
    assert code == 0, err


def test_deeply_nested_sim_memory_file_is_refused(tmp_path: Path) -> None:
    """`mpc sim --memory FILE` (docs/simulator.md): a file that is not a memory file is
    refused with exit 3; nested a thousand deep it was a RecursionError."""
    from mplang.m8194h.sim.controller import VirtualController
    from mplang.m8194h.sim.service import ServiceError, load_memory

    path = write(tmp_path, "memory.json", "[" * 5000 + "]" * 5000)
    with pytest.raises(ServiceError, match="nested more than 32 deep"):
        load_memory(VirtualController(), path)
