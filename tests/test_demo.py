"""`make demo` runs each job with its own sources, so what it prints is that job's: the
variables it names (its `VAR`/`ALIAS` names) and the non-zero ones, not every alias of every
sample of the folder (37 variables, nearly all 0, when it ran `samples/*.mp`)."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHOWN = re.compile(r"^  (\w+)(?: \((VAR\d+)\))? = (-?\d+)$")


def demo_runs() -> list[list[str]]:
    """The arguments of every `mpc run` of the Makefile's demo recipe."""
    recipe = ROOT.joinpath("Makefile").read_text().split("\ndemo:", 1)[1].split("\n\n", 1)[0]
    return [shlex.split(line.split("mpc run", 1)[1]) for line in recipe.splitlines()
            if "/mpc run " in line]


def names_declared(files: list[str]) -> set[str]:
    """The VAR and ALIAS names of `files` and the files they INCLUDE."""
    names: set[str] = set()
    todo = [ROOT / f for f in files]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        text = path.read_text(encoding="utf-8")
        names |= set(re.findall(r"^\s*(?:VAR|ALIAS)\s+(\w+)", text, re.MULTILINE))
        todo += [path.parent / m for m in re.findall(r'^\s*INCLUDE\s+"([^":]+)"', text,
                                                      re.MULTILINE)]
    return names


def test_demo_runs_print_only_their_own_variables() -> None:
    runs = demo_runs()
    assert len(runs) == 2
    for args in runs:
        files = [a for a in args if a.endswith(".mp")]
        assert files and not any("*" in f for f in files), args  # the job's own sources
        done = subprocess.run([sys.executable, "-m", "mplang", "run",
                               *[a for a in args if a != "--json"]], cwd=ROOT,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        shown = [SHOWN.match(line) for line in done.stdout.splitlines()]
        variables = [m for m in shown if m is not None]
        assert variables, done.stdout
        declared = names_declared(files)
        for match in variables:
            name, value = match.group(1), int(match.group(3))
            assert value != 0 or name in declared, (args, match.group(0))
        assert sum(1 for m in variables if int(m.group(3)) == 0) <= 3, done.stdout
