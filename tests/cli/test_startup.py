"""What `mpc` loads before it does anything: `--version` and `--help` nothing of the
compiler, `mpc lint` not the virtual controller. Checked on the modules a fresh interpreter
holds afterwards (what `python -X importtime` would show), never on time."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from mplang.cli import main, short_help_of

HEAVY = ("lark", "mplang.ir.unit", "mplang.lang.parser", "mplang.lang.rules",
         "mplang.tools.project", "mplang.cli.common", "mplang.m8194h", "pymodbus", "pygls")


def _modules_after(*args: str, cwd: Path | None = None) -> set[str]:
    """The modules loaded by `mpc ARGS` in a fresh interpreter."""
    script = ("import json, sys\nfrom mplang.cli import main\n"
              f"try:\n    main({list(args)!r})\nexcept SystemExit:\n    pass\n"
              "sys.stdout.flush()\nprint(json.dumps(sorted(sys.modules)), file=sys.stderr)\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=cwd, check=True)
    return set(json.loads(done.stderr.strip().splitlines()[-1]))


@pytest.mark.parametrize("args", [("--version",), ("--help",)])
def test_version_and_help_load_nothing_heavy(args: tuple[str, ...]) -> None:
    loaded = _modules_after(*args)
    assert "mplang.cli" in loaded
    assert not [m for m in loaded if m.startswith(HEAVY)]


def test_lint_does_not_load_the_virtual_controller(tmp_path: Path) -> None:
    source = tmp_path / "one.mp"
    source.write_text("MP 1\n  SET_V X, 2000\nEND MP\n")
    loaded = _modules_after("lint", str(source), cwd=tmp_path)
    assert "mplang.m8194h.compiler" in loaded
    assert not [m for m in loaded if m.startswith(("mplang.m8194h.sim", "mplang.m8194h.run",
                                                   "pymodbus", "pygls"))]


def test_help_lists_each_command_as_click_would() -> None:
    """The short help read from each command's module is the one its command object gives."""
    context = click.Context(main)
    for name in main.list_commands(context):
        command = main.get_command(context, name)
        assert command is not None
        assert short_help_of(name) == command.get_short_help_str(limit=200)
    listed = CliRunner().invoke(main, ["--help"]).output
    for name in main.list_commands(context):
        assert f"  {name} " in listed
