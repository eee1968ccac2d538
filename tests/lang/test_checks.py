"""Every rule has a failing input in tests/data/checks/<CODE>*.mp that triggers it.

Each input states what it must produce with lines `# expect: CODE LINE` (or
`# expect: CODE LINE:COL`); the test asserts exactly those diagnostics, no more, no fewer.
Inputs may INCLUDE helper files from tests/data/checks/include/. Rules about the project file
have a folder `<CODE>_project/` with an mpc.toml (holding the `# expect:` lines, about its own
lines) and the sources it lists.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from mplang import csim, fatek
from mplang.lang.rules import RULES
from mplang.m8194h.compiler import Options, compile_paths
from mplang.tools.project import load_project

CHECKS = Path(__file__).resolve().parents[1] / "data" / "checks"
EXPECT = re.compile(r"#\s*expect:\s*([EW]\d{3})\s+(\d+)(?::(\d+))?")
OPTIONS = re.compile(r"#\s*options:\s*(.*)")
CASES = sorted([*CHECKS.glob("*.mp"), *CHECKS.glob("*.fbs"), *CHECKS.glob("*.csim")])
PROJECTS = sorted(CHECKS.glob("*_project/mpc.toml"))


def expected(path: Path) -> set[tuple[str, int, int | None]]:
    found = set()
    for match in EXPECT.finditer(path.read_text()):
        col = int(match.group(3)) if match.group(3) else None
        found.add((match.group(1), int(match.group(2)), col))
    return found


def options_for(path: Path) -> Options:
    match = OPTIONS.search(path.read_text())
    if not match:
        return Options()
    settings = dict(item.split("=") for item in match.group(1).split())
    return Options(target=settings.get("target", "et"))


@pytest.mark.parametrize("path", CASES, ids=[p.name for p in CASES])
def test_check_input(path: Path) -> None:
    options = options_for(path)
    if path.suffix in fatek.SUFFIXES:
        result = fatek.check_native([path])
    elif options.target in fatek.TARGETS:
        result = fatek.compile_mp([path], options, options.target)
    elif path.suffix in csim.SUFFIXES:
        result = csim.check_native([path])
    elif options.target in csim.TARGETS:
        result = csim.compile_mp([path], options, options.target)
    else:
        result = compile_paths([path], options)
    want = expected(path)
    assert want, f"{path.name} declares no '# expect:' lines"
    got = {(d.code, d.span.line, d.span.col) for d in result.diagnostics}
    got_loose = {(code, line, None) for code, line, _ in got}
    matched = {w for w in want if (w in got if w[2] is not None else w in got_loose)}
    missing = want - matched
    extra = {g for g in got if (g not in want and (g[0], g[1], None) not in want)}
    rendered = "\n".join(d.render() for d in result.diagnostics)
    assert not missing and not extra, f"missing {missing}, extra {extra}\n{rendered}"


@pytest.mark.parametrize("path", PROJECTS, ids=[p.parent.name for p in PROJECTS])
def test_check_project(path: Path) -> None:
    project = load_project(path)
    options = Options(pins=project.pins)
    if project.var_pool is not None:
        options = options.replace(var_pool=project.var_pool)
    result = compile_paths(list(project.sources), options)
    files = [path, *project.sources]
    want = {(f.name, code, line) for f in files for code, line, _ in expected(f)}
    assert want, f"{path.parent} declares no '# expect:' lines"
    got = {(Path(d.span.file).name, d.code, d.span.line) for d in result.diagnostics}
    assert got == want, "\n".join(d.render() for d in result.diagnostics)


def test_every_rule_has_a_failing_input() -> None:
    project_files = [f for p in PROJECTS for f in p.parent.iterdir() if f.is_file()]
    covered = {code for path in [*CASES, *project_files] for code, _, _ in expected(path)}
    assert sorted(set(RULES) - covered) == []
