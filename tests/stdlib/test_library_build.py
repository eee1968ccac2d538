"""The library as a whole: every `std:` file builds clean with example CONSTs, needs exactly
the CONSTs it documents, uses no compiler temporaries, fits the slots docs/stdlib.md gives;
the page's examples build and run; `std:` includes resolve from the package (also from an
installed wheel) without the project check, and a wrong name is E102."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from library_support import TEMPORARY_POOL, build, consts, load, run
from sourcebuild import checkout_build

from mplang.lang import sources
from mplang.m8194h.compiler import BuildResult, compile_paths, compile_source
from mplang.m8194h.sim.axis_io import AxisSensors

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "stdlib.md"

# example CONSTs per library file (a build of all files together shares STD_JOG_*)
EXAMPLE_CONSTS: dict[str, dict[str, int]] = {
    "home_switch.mp": {"STD_HOME_SWITCH_DIR": 2, "STD_HOME_SWITCH_NEAR": 1,
                       "STD_HOME_SWITCH_HV": 2000, "STD_HOME_SWITCH_OFFSET": 5000},
    "home_servo.mp": {"STD_HOME_SERVO_DIR": 2, "STD_HOME_SERVO_NEAR": 1,
                      "STD_HOME_SERVO_HV": 500, "STD_HOME_SERVO_OFFSET": 3500},
    "home_limit.mp": {"STD_HOME_LIMIT_DIR": 2, "STD_HOME_LIMIT_HV": 5000,
                      "STD_HOME_LIMIT_OFFSET": 1000},
    "home_index.mp": {"STD_HOME_INDEX_DIR": 1, "STD_HOME_INDEX_HV": 2000,
                      "STD_HOME_INDEX_OFFSET": 200},
    "jog.mp": {"STD_JOG_AXIS": 1, "STD_JOG_V": 5000},
    "jog_return.mp": {"STD_JOG_AXIS": 1, "STD_JOG_V": 5000, "STD_JOG_START": 20_000,
                      "STD_JOG_DI_GROUP": 8, "STD_JOG_DI_CHANNEL": 2,
                      "STD_JOG_TIMEOUT_MS": 3000},
    "rectangle.mp": {"STD_RECT_AXIS1": 1, "STD_RECT_AXIS2": 2, "STD_RECT_WIDTH": 30_000,
                     "STD_RECT_HEIGHT": 20_000, "STD_RECT_VSV": 1000, "STD_RECT_VV": 20_000,
                     "STD_RECT_VA": 100_000},
    "circle.mp": {"STD_CIRCLE_AXIS1": 1, "STD_CIRCLE_AXIS2": 2, "STD_CIRCLE_CX": 10_000,
                  "STD_CIRCLE_CY": 0, "STD_CIRCLE_VSV": 1000, "STD_CIRCLE_VV": 20_000,
                  "STD_CIRCLE_VA": 100_000},
    "grid.mp": {"STD_GRID_AXIS1": 1, "STD_GRID_AXIS2": 2, "STD_GRID_COLS": 3,
                "STD_GRID_ROWS": 2, "STD_GRID_PITCH_1": 1000, "STD_GRID_PITCH_2": 1000},
    "estop.mp": {"STD_ESTOP_DO_GROUP": 0, "STD_ESTOP_DO_SAFE": 8},
    "pick_and_place.mp": {"STD_PP_PICK_X": 1000, "STD_PP_PICK_Y": 2000,
                          "STD_PP_PLACE_X": 3000, "STD_PP_PLACE_Y": 4000,
                          "STD_PP_DO_GROUP": 0, "STD_PP_DO_Z": 1, "STD_PP_DO_GRIP": 0,
                          "STD_PP_DI_GROUP": 8, "STD_PP_DI_PART": 0,
                          "STD_PP_PART_TIMEOUT_MS": 1000, "STD_PP_STROKE_MS": 100,
                          "STD_PP_GRIP_MS": 100},
}
# what a file needs besides CONSTs: std:grid.mp calls the project's std_grid_point
PROJECT_PARTS = {"grid.mp": "MP std_grid_point\n    TIMER 10\nEND MP\n"}


def include(name: str) -> str:
    return f'INCLUDE "std:{name}"\n' + PROJECT_PARTS.get(name, "")


def everything() -> BuildResult:
    merged = {k: v for values in EXAMPLE_CONSTS.values() for k, v in values.items()}
    return build(consts(**merged) + "".join(include(name) for name in EXAMPLE_CONSTS))


def test_every_library_file_has_example_consts_here() -> None:
    assert set(sources.library_files()) == set(EXAMPLE_CONSTS)


@pytest.mark.parametrize("name", sorted(EXAMPLE_CONSTS))
def test_each_file_builds_clean_with_its_consts(name: str) -> None:
    result = build(consts(**EXAMPLE_CONSTS[name]) + include(name))
    library = [p for p in result.programs if p.program.source.startswith("std:")]
    assert library and all(p.placement.auto for p in library)
    assert all(p.program.name and p.program.name.startswith("std_") for p in library)


def header(name: str) -> str:
    """The comment block at the top of a library file."""
    text = (sources.library_files()[name]).read_text(encoding="utf-8")
    return "".join(line for line in text.splitlines(keepends=True)[:200]
                   if line.startswith("#")).split("\n\n")[0]


@pytest.mark.parametrize("name", sorted(EXAMPLE_CONSTS))
def test_a_file_needs_exactly_the_consts_it_documents(name: str) -> None:
    text = sources.library_files()[name].read_text(encoding="utf-8")
    code = "".join(line.split("#")[0] + "\n" for line in text.splitlines())
    internal = set(re.findall(r"^CONST (STD_\w+)", code, re.MULTILINE))
    used = set(re.findall(r"\bSTD_[A-Z0-9_]+", code)) - internal
    assert used == set(EXAMPLE_CONSTS[name])
    assert used <= set(re.findall(r"\bSTD_[A-Z0-9_]+", header(name)))
    docs = DOCS.read_text(encoding="utf-8")
    assert all(f"`{const}`" in docs for const in used | internal)
    for missing in used:  # each of them is really needed
        others = {k: v for k, v in EXAMPLE_CONSTS[name].items() if k != missing}
        assert not compile_source(consts(**others) + include(name)).ok, missing


def frame_variables(frame: list[int]) -> set[int]:
    """The VARn operands of a frame in word order 0 (0x7FFF, n); no constant in the
    +-2,000,000,000 range has 0x7FFF as its high word."""
    return {frame[i + 1] for i in range(1, len(frame) - 1) if frame[i] == 0x7FFF}


def test_library_programs_use_no_compiler_temporaries() -> None:
    result = everything()
    assert result.word_order == 0
    library = [p for p in result.programs if p.program.source.startswith("std:")]
    assert len(library) == 13
    for image in library:
        used = set().union(*(frame_variables(f) for f in image.frames))
        assert used, image.program.name  # the scan sees variables at all
        assert not used & set(TEMPORARY_POOL), image.program.name


def test_the_slot_table_of_the_docs_matches_the_build() -> None:
    rows = re.findall(r"^\| `std:([\w.]+)` \| `(\w+)` \| (MP|ISR) \| (\d+) \| (\d+) \|$",
                      DOCS.read_text(encoding="utf-8"), re.MULTILINE)
    built = {p.program.name: (p.program.source, p.program.kind.upper(), p.placement.lines_used,
                              p.placement.budget)
             for p in everything().programs if p.program.source.startswith("std:")}
    documented = {routine: (f"std:{file}", kind, int(lines), int(budget))
                  for file, routine, kind, lines, budget in rows}
    assert documented == built


def docs_examples() -> list[str]:
    return re.findall(r"^```mp\n(.*?)^```$", DOCS.read_text(encoding="utf-8"),
                      re.MULTILINE | re.DOTALL)


def test_docs_have_an_example_for_every_file() -> None:
    examples = docs_examples()
    for name in EXAMPLE_CONSTS:
        assert any(f'INCLUDE "std:{name}"' in example for example in examples), name


@pytest.mark.parametrize("example", docs_examples(),
                         ids=[re.search(r"std:(\w+)", e).group(1)  # type: ignore[union-attr]
                              for e in docs_examples()])
def test_docs_examples_build_clean_and_run(example: str) -> None:
    """On a machine with limit switches at +-500,000 on every axis (std_home_limit needs
    one) and otherwise the virtual controller's default sensors."""
    result = build(example)
    machine = AxisSensors(limit_plus=500_000, limit_minus=-500_000)
    vc = load(result, dict.fromkeys(range(4), machine))
    run(vc, result, next(p.program.name or "" for p in result.programs
                         if p.program.source == "main.mp" and p.program.kind == "mp"))


def test_an_unknown_library_file_is_e102_naming_the_files() -> None:
    for wrong in ("std:no_such.mp", "std:m8194h/commands.toml", "std:__init__.py"):
        result = compile_source(f'INCLUDE "{wrong}"\nMP 1\nEND MP\n')
        (diagnostic,) = result.diagnostics
        assert (diagnostic.code, diagnostic.span.line) == ("E102", 1)
        assert wrong in diagnostic.message
        assert "std:jog.mp" in diagnostic.hint and "std:estop.mp" in diagnostic.hint


def test_std_includes_need_no_permission_to_leave_the_project(tmp_path: Path) -> None:
    project = tmp_path / "machine"
    (project / ".git").mkdir(parents=True)
    main = project / "main.mp"
    main.write_text(consts(**EXAMPLE_CONSTS["jog.mp"]) + include("jog.mp"), encoding="utf-8")
    result = compile_paths([main])
    assert result.diagnostics == []
    assert [p.program.source for p in result.programs] == ["std:jog.mp"]


def test_an_include_inside_a_library_file_names_another_library_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    library = tmp_path / "library"
    library.mkdir()
    (library / "a.mp").write_text('INCLUDE "b.mp"\nMP std_a\n    VAR1 = STD_B\nEND MP\n')
    (library / "b.mp").write_text("CONST STD_B = 7\n")
    (library / "x.mp").write_text('INCLUDE "std:y.mp"\n')
    (library / "y.mp").write_text('INCLUDE "x.mp"\n')
    (tmp_path / "b.mp").write_text("CONST STD_B = 99\n")  # beside the project: not this one
    monkeypatch.setattr(sources, "library_files",
                        lambda: {p.name: p for p in library.glob("*.mp")})
    result = compile_paths([_write(tmp_path / "main.mp", 'INCLUDE "std:a.mp"\n')])
    assert result.diagnostics == []
    assert {p.program.source for p in result.programs} == {"std:a.mp"}
    result = compile_paths([_write(tmp_path / "cycle.mp", 'INCLUDE "std:x.mp"\n')])
    (diagnostic,) = result.diagnostics
    assert diagnostic.code == "E103"
    assert "std:x.mp -> std:y.mp -> std:x.mp" in diagnostic.message


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_std_includes_work_from_an_installed_wheel(
        tmp_path: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    """The wheel is imported as a zip file, with the working directory elsewhere: the
    library files come out of the zip, not from the source tree."""
    wheels = tmp_path / "wheel"
    with checkout_build(tmp_path_factory.getbasetemp()):
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                        "--no-build-isolation", "-q", "-w", str(wheels), str(ROOT)],
                       check=True, capture_output=True)
    (wheel,) = wheels.glob("mplang-*.whl")
    source = consts(**EXAMPLE_CONSTS["jog_return.mp"]) + include("jog_return.mp")
    script = (
        "import json, sys, mplang\n"
        "assert mplang.__file__.startswith(sys.argv[1]), mplang.__file__\n"
        "from mplang.m8194h.compiler import compile_source\n"
        "r = compile_source(sys.argv[2])\n"
        "print(json.dumps([[d.render() for d in r.diagnostics],\n"
        "                  [[p.program.source, p.frames] for p in r.programs]]))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script, str(wheel), source], cwd=tmp_path,
                          env={"PYTHONPATH": str(wheel), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    diagnostics, programs = json.loads(proc.stdout)
    assert diagnostics == []
    here = build(source)
    assert programs == [[p.program.source, p.frames] for p in here.programs]
    assert {source for source, _frames in programs} == {"std:jog.mp", "std:jog_return.mp"}
