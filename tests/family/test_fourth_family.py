"""A fourth family is one package and one registry line: with the toy family of
`toy_family.py` registered, `mpc build`, `lint`, `run`, `sim`, `flash` and `disasm` reach it
and speak of it in its own words, though nothing in `mpc` names it."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_SOURCE_ERRORS, EXIT_USAGE, main
from mplang.family import registry

HERE = Path(__file__).resolve().parent


@pytest.fixture
def toy(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Iterator[Path]:
    monkeypatch.syspath_prepend(str(HERE))
    monkeypatch.setattr(registry, "FAMILIES", (*registry.FAMILIES, registry.Registered(
        "toy_family", ("toy",), (".toy",))))
    listing = tmp_path / "job.toy"
    listing.write_text("MOVE 5\nMOVE -2\n")
    yield listing
    sys.modules.pop("toy_family", None)


def run(*args: object) -> tuple[int, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.output


def test_build_lint_and_run_reach_the_fourth_family(toy: Path, tmp_path: Path) -> None:
    assert run("build", toy) == (0, "MOVE 5\nMOVE -2\n")
    code, out = run("build", toy, "--format", "json")
    assert code == 0 and '"moves": [5, -2]' in out
    assert run("lint", toy)[0] == 0
    code, out = run("run", toy, "--json")
    assert code == 0 and '"lp": 3.0' in out
    trace = tmp_path / "t.csv"
    code, out = run("run", toy, "--trace", trace)
    assert code == 0 and "on the virtual Toy stepper" in out
    assert trace.read_text().splitlines()[0].startswith("time_s,X_lp")


def test_its_errors_and_refusals_are_in_its_own_words(toy: Path) -> None:
    toy.write_text("JUMP 3\n")
    code, out = run("build", toy)
    assert code == EXIT_SOURCE_ERRORS and "not a toy line" in out
    toy.write_text("MOVE 1\n")
    code, out = run("run", toy, "--call", "other")
    assert code == EXIT_USAGE and "callable: main" in out
    code, out = run("sim", toy, "--serial", "pty")
    assert code == EXIT_USAGE and "no Toy stepper device to serve: a toy has no wire" in out
    code, out = run("flash", toy, "--serial", "/dev/null")
    assert code == EXIT_USAGE and "cannot be flashed: a toy has no wire. Copy the listing" \
        in " ".join(out.split())
    code, out = run("build", toy, "--format", "hex")
    assert code == EXIT_USAGE and "not a format of Toy stepper builds" in " ".join(out.split())
