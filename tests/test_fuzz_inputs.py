"""Fuzzing every command's input: mutated samples never make mplang fail with anything but a
diagnostic or a documented error (issue 19, finding 5).

The samples (`samples/*.mp`, the family samples `samples/fatek/*`, `samples/csim/*`), an
image JSON built from them and a project file are mutated line by line (deleted, doubled,
swapped, cut, characters replaced) and with hostile lines: numbers of thousands of digits,
expressions and blocks nested a thousand deep, unbalanced blocks, raw IFs with bad
operators, CONSTs defined through a thousand others. Each mutant goes through the library
entry point of every command that reads it (`compile_mp` of every family, which `mpc build`
and `mpc lint` call, `run_build` with a short `max_time`, `format_source`, `check_native`,
`load_image` and `disassemble`, `load_project`); only the documented errors may escape. A
handful of mutants per command then go through the CLI itself: never exit 70 (internal
error), never a traceback.

Runs are derandomised so the suite is repeatable and bounded (about 20 s in all here); set
MPLANG_FUZZ=N to run N times as many examples, freshly random, when hunting.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from outcomes import assert_diagnostics, assert_refusal

from mplang import csim, fatek, m8194h
from mplang.cli import main
from mplang.family.face import RunSetupError
from mplang.ir.unit import Options
from mplang.m8194h import disasm
from mplang.m8194h.flash import ImageError, load_image
from mplang.tools.fmt import SourceNotFormattable, format_source
from mplang.tools.project import ProjectError, load_project

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"
MP_SEEDS = sorted(SAMPLES.glob("*.mp"))
FAMILY_MP_SEEDS = sorted([*SAMPLES.glob("fatek/*.mp"), *SAMPLES.glob("csim/*.mp"),
                          *SAMPLES.glob("families/*.mp")])
FBS_SEEDS = sorted(SAMPLES.glob("fatek/*.fbs"))
CSIM_SEEDS = sorted(SAMPLES.glob("csim/*.csim"))

# The strategies hold the hostile lines, so their repr is long; it is never shown.
pytestmark = pytest.mark.filterwarnings("ignore:Generating overly large repr")
SCALE = int(os.environ.get("MPLANG_FUZZ", "0") or 0)
INTERNAL = 70


def fuzz_settings(examples: int) -> settings:
    """Bounded and repeatable by default; MPLANG_FUZZ=N: N times more, freshly random."""
    # Every health check stays on (an empty or over-filtered strategy fails) except these:
    # too_slow, as each example builds and runs programs; data_too_large and
    # large_base_example, as the hostile lines are thousands of characters by design.
    return settings(max_examples=examples * max(SCALE, 1), deadline=None, database=None,
                    derandomize=SCALE == 0,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.large_base_example])


# ------------------------------------------------------------------------ mutations

HOSTILE_MP = [
    "VAR1 = " + "9" * 5000,
    "VAR1 = 0x" + "F" * 5000,
    "VAR1 = 000" + "1" * 25,
    "VAR2 = " + "+".join(["VAR1"] * 1000),
    "VAR2 = " + "(" * 1000 + "1" + ")" * 1000,
    "VAR2 = " + "-" * 1000 + "VAR1", "VAR2 = " + "- " * 1000 + "5", "VAR2 = " + "+" * 1000 + "1",
    "VAR2 = " + "ABS(" * 400 + "1" + ")" * 400,
    "FIXED_MOVE X, " + "+".join(["1"] * 600),
    "IF VAR1 == 1\n" * 1000 + "VAR1 = 2\n" + "END IF\n" * 1000,
    "FOR 2\n" * 300 + "NEXT\n" * 300,
    "WHILE VAR1 < 3\n" * 100 + "END WHILE\n" * 100,
    "IF " + "+".join(["VAR1"] * 500) + " == 1",
    "VAR speed\nVAR2 = " + "+".join(["speed"] * 1000),
    "CONST C0 = 1\n" + "\n".join(f"CONST C{i} = C{i - 1} + 1" for i in range(1, 1200)),
    "CONST BIG = 2000000000 + 2000000000",
    "VAR2 = 2000000000 * 2000000000 * 2000000000",
    "RSM_MACRO_IF VAR1, 0x99, 1", "RSM_MACRO_IF VAR1, EQ, 1", "RSM_MACRO_IF VAR1, \"=~\", 1",
    "RSM_MACRO_IF VAR1, C0 + 1, 1", "IF VAR1 == 1", "ELSE", "END IF", "END_IF", "ELSE 2",
    "NEXT", "FOR 3", "FOR -5", "EXIT FOR", "EXIT", "END MP", "MP 1", "MP 999 x", "ISR 3",
    "END ISR", "REPEAT 3", "END REPEAT", "INIT", "END INIT", "TRIGGERS", "INTERRUPTS MP 1",
    "ON X P>=C+ CALL ISR 3", "ON DI 8.0 OFF_TO_ON CALL MP1", "LABEL 9", "GOTO 9", "LABEL x",
    "GOTO x", "CALL MP999", "CALL nowhere", "VAR w @ VAR600", "ALIAS a = VAR9999",
    'INCLUDE "nonexistent.mp"', "VAR3 = 1 / 0", "VAR3 = GET_LP(X) / 0", "SET_V X, 1e9",
    "\t\x00\x7f", "\ufeffMP 2", "VAR1 = \"text\"", "FIXED_MOVE", "FIXED_MOVE X,,,,",
]
HOSTILE_FBS = [
    "001 SPD " + "9" * 5000, "001 SPD 0x" + "F" * 5000, "001 SPD 0" + "F" * 5000 + "H",
    "TABLE t FUN140 Ps0", "TABLE t FUN141 Ps9", "001 DRV ADR,+," + "1" * 40 + ",Ps",
    "002 DRV ABS,,0,Ut", "003 GOTO NEXT", "004 WAIT X" + "9" * 5000, "P0 = " + "7" * 5000,
    "P99 = 1", "SIM axis 0 pulses 5", "SIM window X0 Ps0 9 1", "005 DRVC ABS,+,1,Ps",
    "D" + "1" * 5000, "\x00", "001",
]
HOSTILE_CSIM = [
    "N0=" + "9" * 5000, "R0=0." + "1" * 5000, "N1=" + "7" * 25, "NS(" + "9" * 5000 + ")=1",
    "JP $nowhere", "CALL $nowhere", "RET", "PN50=" + "1" * 5000, "MA " + "9" * 5000,
    "DATA N64," + "9" * 5000, "JE 1,N0,$x", "OUT \"unterminated", "T" + "9" * 5000,
    "\x00",
]
CHARACTERS = st.characters(codec="utf-8", exclude_categories=("Cs",))


@st.composite
def mutated(draw: st.DrawFn, seeds: list[Path], hostile: list[str]) -> tuple[Path, str]:
    """A seed file's text after a few line and character mutations and hostile lines."""
    seed = draw(st.sampled_from(seeds))
    lines = seed.read_text(encoding="utf-8").split("\n")
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["hostile", "hostile", "delete", "double", "swap", "char",
                                     "random", "cut"]))
        at = draw(st.integers(0, max(len(lines) - 1, 0)))
        if kind == "hostile":
            lines.insert(at, draw(st.sampled_from(hostile)))
        elif kind == "delete" and lines:
            del lines[at]
        elif kind == "double" and lines:
            lines.insert(at, lines[at])
        elif kind == "swap" and lines:
            other = draw(st.integers(0, len(lines) - 1))
            lines[at], lines[other] = lines[other], lines[at]
        elif kind == "char" and lines and lines[at]:
            col = draw(st.integers(0, len(lines[at]) - 1))
            lines[at] = lines[at][:col] + draw(CHARACTERS) + lines[at][col + 1:]
        elif kind == "random":
            lines.insert(at, draw(st.text(CHARACTERS, max_size=40)))
        elif kind == "cut" and lines:
            lines = lines[:at + 1]
            lines[-1] = lines[-1][:draw(st.integers(0, len(lines[-1])))]
    return seed, "\n".join(lines)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the samples, so mutants sit beside the files they INCLUDE."""
    root = tmp_path_factory.mktemp("fuzz")
    shutil.copytree(SAMPLES, root / "samples")
    (root / ".git").mkdir()  # the project root for the INCLUDE checks
    return root


def place(workspace: Path, seed: Path, text: str) -> Path:
    """Write a mutant of `seed` beside the seed's copy in the workspace."""
    target = workspace / seed.relative_to(ROOT).parent / f"mutant{seed.suffix}"
    target.write_text(text, encoding="utf-8")
    return target


def run_if_ok(family: object, build: object) -> None:
    """The build's diagnostics, then `mpc run` of a build without errors, briefly: a run
    report, or a RunSetupError that says why (documented: exit 5, or a usage error)."""
    assert_diagnostics(build)
    if not getattr(build, "ok", False):
        return
    try:
        report = family.run_build(build, None, 0.2)  # type: ignore[attr-defined]
    except RunSetupError as refused:
        assert str(refused), "a refusal without a reason"
        return
    assert isinstance(report.called, str) and report.called
    assert report.error is None or (isinstance(report.error, str) and report.error)


# ---------------------------------------------------------------- library entry points

@fuzz_settings(40)
@given(mutant=mutated(MP_SEEDS, HOSTILE_MP))
def test_mp_mutants_only_give_diagnostics(workspace: Path, mutant: tuple[Path, str]) -> None:
    """build / lint / run / fmt of a mutated .mp sample, for the M8194H and both other
    families: diagnostics, never an exception."""
    seed, text = mutant
    path = place(workspace, seed, text)
    build = m8194h.compile_mp([path], Options(), "et")
    run_if_ok(m8194h, build)
    for family, target in ((fatek, "fbs-fun140"), (csim, "csim")):
        assert_diagnostics(family.compile_mp([path], Options(target=target), target))
    try:
        formatted = format_source(text, name=str(path))
    except SourceNotFormattable:
        return
    assert format_source(formatted) == formatted  # the layout is a fixed point


@fuzz_settings(40)
@given(mutant=mutated(FAMILY_MP_SEEDS, HOSTILE_MP))
def test_family_mp_mutants_only_give_diagnostics(workspace: Path,
                                                 mutant: tuple[Path, str]) -> None:
    """The family samples written in .mp, compiled and run for FATEK and CSIM."""
    seed, text = mutant
    path = place(workspace, seed, text)
    for family, target in ((fatek, "fbs-fun140"), (fatek, "fbs-fun147"), (csim, "csim")):
        run_if_ok(family, family.compile_mp([path], Options(target=target), target))


@fuzz_settings(40)
@given(mutant=mutated(FBS_SEEDS, HOSTILE_FBS))
def test_fbs_mutants_only_give_diagnostics(workspace: Path, mutant: tuple[Path, str]) -> None:
    seed, text = mutant
    path = place(workspace, seed, text)
    run_if_ok(fatek, fatek.check_native([path]))


@fuzz_settings(40)
@given(mutant=mutated(CSIM_SEEDS, HOSTILE_CSIM))
def test_csim_mutants_only_give_diagnostics(workspace: Path, mutant: tuple[Path, str]) -> None:
    seed, text = mutant
    path = place(workspace, seed, text)
    run_if_ok(csim, csim.check_native([path]))


# ------------------------------------------------------------------------- images

JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False)
    | st.text(max_size=8) | st.sampled_from([10 ** 4000, -(2 ** 70), "0x3D3D", "MP1"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner,
                                                                 max_size=3),
    max_leaves=6)


@pytest.fixture(scope="module")
def image_text(workspace: Path) -> str:
    build = m8194h.compile_mp(MP_SEEDS, Options(), "et")
    assert build.ok, [d.render() for d in build.diagnostics]
    return build.render("json")


def _mutate_json(data: object, draw: st.DrawFn) -> object:
    """Replace or drop one value somewhere inside `data` (walked to a random depth)."""
    if isinstance(data, dict) and data and draw(st.booleans()):
        key = draw(st.sampled_from(sorted(data)))
        if draw(st.integers(0, 4)) == 0:
            return {k: v for k, v in data.items() if k != key}
        return {**data, key: _mutate_json(data[key], draw)}
    if isinstance(data, list) and data and draw(st.booleans()):
        index = draw(st.integers(0, len(data) - 1))
        return [*data[:index], _mutate_json(data[index], draw), *data[index + 1:]]
    return draw(JSON_VALUES)


@st.composite
def image_mutants(draw: st.DrawFn, text: str) -> str:
    kind = draw(st.sampled_from(["value", "value", "value", "deep", "cut", "number"]))
    if kind == "value":
        return json.dumps(_mutate_json(json.loads(text), draw))
    if kind == "deep":
        depth = draw(st.integers(30, 3000))
        cut = text.rindex("}")
        return f'{text[:cut]}, "extra": {"[" * depth}{"]" * depth}}}'
    if kind == "number":
        return text.replace('"word_order": 0', f'"word_order": {"9" * 5000}', 1)
    return text[:draw(st.integers(0, len(text)))]


def test_image_mutants_only_give_image_errors(workspace: Path, image_text: str) -> None:
    """`mpc disasm` and `mpc flash` read an image with load_image; only ImageError escapes,
    and what it accepts disassembles."""
    path = workspace / "mutant.image.json"

    @fuzz_settings(30)
    @given(text=image_mutants(image_text))
    def check(text: str) -> None:
        path.write_text(text, encoding="utf-8")
        try:
            image = load_image(path)
        except ImageError as refused:
            assert_refusal(refused, str(path))
            return
        result = disasm.disassemble(image)
        assert isinstance(result.text, str) and result.text
        assert result.exact or (result.problems and all(result.problems))

    check()


# -------------------------------------------------------------------- project files

PROJECT = """[project]
sources = ["samples/tour.mp", "samples/*.mp"]
target = "et"
temp-vars = "500-511"
var-pool = "400-499"

[slots]
tour = 21

[flash]
timeout = 0.5
retries = 2

[targets.cell]
address = "127.0.0.1:1502"
"""
HOSTILE_TOML = [
    'sources = "/tmp/*.mp"', f'sources = "{"a" * 300}"', 'sources = "a**b/*.mp"',
    'sources = "x\\u0000y"', 'sources = []', 'sources = [1, 2]', f"word-order = {'9' * 5000}",
    'temp-vars = "511-500"', "tour = 9999", f"timeout = 1e{'9' * 400}", "retries = -1",
    'address = "[::1"', 'address = "host:99999"', "[targets.x]\nserial = 5", "[nothing]",
    'sources = "samples"', "fmt = 1", "[fmt]\nindent = 99",
]


def test_project_mutants_only_give_project_errors(workspace: Path) -> None:
    path = workspace / "mpc.toml"
    seed = workspace / "seed.toml"
    seed.write_text(PROJECT)

    @fuzz_settings(60)
    @given(mutant=mutated([seed], HOSTILE_TOML))
    def check(mutant: tuple[Path, str]) -> None:
        path.write_text(mutant[1], encoding="utf-8")
        try:
            project = load_project(path)
        except ProjectError as refused:
            assert_refusal(refused, str(path))
            return
        assert project is not None

    check()


# -------------------------------------------------------------------------- the CLI

def no_internal_error(args: list[str]) -> None:
    result = CliRunner().invoke(main, args)
    assert result.exit_code != INTERNAL, result.stderr
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, \
        result.stderr
    if result.exception is not None:  # anything but SystemExit is a crash through click
        assert isinstance(result.exception, SystemExit), repr(result.exception)


CLI_MP: list[Callable[[Path], list[str]]] = [
    lambda p: ["build", str(p)], lambda p: ["lint", str(p)],
    lambda p: ["run", "--max-time", "0.2", str(p)], lambda p: ["fmt", "--check", str(p)],
    lambda p: ["build", "--target", "csim", str(p)],
    lambda p: ["lint", "--target", "fbs-fun140", str(p)],
]


@pytest.mark.parametrize("command", range(len(CLI_MP)),
                         ids=[" ".join(c(Path("F"))[:-1]) for c in CLI_MP])
def test_cli_never_fails_internally_on_mp(workspace: Path, command: int) -> None:
    @fuzz_settings(6)
    @given(mutant=mutated(MP_SEEDS, HOSTILE_MP))
    def check(mutant: tuple[Path, str]) -> None:
        no_internal_error(CLI_MP[command](place(workspace, *mutant)))

    check()


@pytest.mark.parametrize("suffix", [".fbs", ".csim"])
def test_cli_never_fails_internally_on_native(workspace: Path, suffix: str) -> None:
    seeds, hostile = (FBS_SEEDS, HOSTILE_FBS) if suffix == ".fbs" else (CSIM_SEEDS,
                                                                         HOSTILE_CSIM)

    @fuzz_settings(6)
    @given(mutant=mutated(seeds, hostile), command=st.sampled_from(["build", "lint", "run"]))
    def check(mutant: tuple[Path, str], command: str) -> None:
        path = place(workspace, *mutant)
        no_internal_error([command, *(["--max-time", "0.2"] if command == "run" else []),
                           str(path)])

    check()


@pytest.mark.parametrize("command", [["disasm"], ["flash", "--dry-run"]])
def test_cli_never_fails_internally_on_images(workspace: Path, image_text: str,
                                              command: list[str]) -> None:
    path = workspace / "cli.image.json"

    @fuzz_settings(6)
    @given(text=image_mutants(image_text))
    def check(text: str) -> None:
        path.write_text(text, encoding="utf-8")
        no_internal_error([*command, str(path)])

    check()
