"""The `mpc` examples of the family pages (docs/fatek.md, docs/csim.md, the families section
of docs/cli.md) run as written: each exits 0, or with the code its comment says
(`# exit 5: ...`). Examples that need a device or serve one (flash, sim) are exercised by
tests/cli/commands/test_flash_families.py and test_sim_families.py instead."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAGES = ("fatek.md", "csim.md", "cli.md")


def examples() -> list[tuple[str, str, int]]:
    found = []
    for page in PAGES:
        text = (ROOT / "docs" / page).read_text("utf-8")
        for block in re.findall(r"```sh\n(.*?)```", text, re.DOTALL):
            for line in block.splitlines():
                command, _, comment = line.partition("  #")
                words = shlex.split(command)
                if not words or words[0] != "mpc" or words[1] in ("flash", "sim"):
                    continue
                code = re.match(r"\s*exit (\d+)", comment)
                found.append((page, command.strip(), int(code.group(1)) if code else 0))
    return found


EXAMPLES = examples()


def test_the_pages_have_examples_for_every_command_that_runs_locally() -> None:
    commands = {shlex.split(command)[1] for _, command, _ in EXAMPLES}
    assert commands == {"lint", "build", "run", "plot"}
    assert {page for page, _, _ in EXAMPLES} == set(PAGES)


@pytest.mark.parametrize(("page", "command", "code"), EXAMPLES,
                         ids=[f"{page}:{command}" for page, command, _ in EXAMPLES])
def test_the_example_runs(page: str, command: str, code: int, tmp_path: Path,
                          monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "samples").symlink_to(ROOT / "samples")
    monkeypatch.chdir(tmp_path)  # files the example writes land here
    result = CliRunner().invoke(main, shlex.split(command)[1:])
    assert result.exit_code == code, (page, result.output)
    assert "internal error" not in result.output
