"""What `mpc` loads before it does anything: `--version` and `--help` nothing of the
compiler, `mpc lint` not the virtual controller, a build whose every file hits the front
cache not lark, `mpc flash` and `mpc status` not the Modbus server (nor aiohttp, which it
brings, nor the virtual controller), `mpc sim` not the monitor unless asked. Checked on
the modules a fresh interpreter holds afterwards (what `python -X importtime` would show),
never on time."""

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


NEVER_FOR_VERSION = ("dataclasses", "hashlib", "_hashlib", "platformdirs", "tempfile", "pickle")
"""What `mpc --version` and `mpc --help` never need either: no record or cache is read."""


@pytest.mark.parametrize("args", [("--version",), ("--help",)])
def test_version_and_help_load_nothing_heavy(args: tuple[str, ...]) -> None:
    loaded = _modules_after(*args)
    assert "mplang.cli" in loaded
    assert not [m for m in loaded if m.startswith(HEAVY)]
    assert _loaded(loaded, NEVER_FOR_VERSION) == []


def test_lint_does_not_load_the_virtual_controller(tmp_path: Path) -> None:
    source = tmp_path / "one.mp"
    source.write_text("MP 1\n  SET_V X, 2000\nEND MP\n")
    loaded = _modules_after("lint", str(source), cwd=tmp_path)
    assert "mplang.m8194h.compiler" in loaded
    assert not [m for m in loaded if m.startswith(("mplang.m8194h.sim", "mplang.m8194h.run",
                                                   "pymodbus", "pygls"))]


NEVER_FOR_A_BUILD = ("lark", "difflib", "pymodbus.server", "aiohttp", "mplang.cli.commands.monitor",
                     "mplang.tools.monitor.server", "mplang.m8194h.debugger",
                     "mplang.m8194h.run", "mplang.cli.commands.dap", "mplang.tools.dap",
                     "mplang.family.debug", "mplang.family.trace", "mplang.family.hostview",
                     "mplang.family.watch", "mplang.family.run_error", "pkgutil", "glob",
                     "click.shell_completion", "mplang.tools.report", "importlib.resources",
                     "zipfile")
"""What `mpc lint` and `mpc flash --dry-run` whose files all hit the front cache, and `mpc
status`, never need: the host view, pkgutil (the commands are listed from their
directory), glob (for a file pattern only), click's shell completion (when the shell
asks), the machine-read report formats, importlib.resources and zipfile (the package's
files are read from its directory; a library INCLUDE or a zip import needs them)."""

NEVER_ON_A_HIT = ("tomllib",)
"""What a run whose catalogue comes from the cache an earlier run filled, without an
mpc.toml, never needs: tomllib (the TOML files are parsed on a miss only)."""

NEVER_FOR_A_LINT = ("hashlib", "_hashlib", "platformdirs", "tempfile", "shutil", "random")
"""What `mpc lint` that hits its caches never needs: hashlib and OpenSSL's _hashlib behind
it (keys and build ids are `mplang.lang.digest`'s; `mpc flash` loads them with filelock,
which imports `secrets`), and, where MPLANG_CACHE or XDG_CACHE_HOME names the cache,
platformdirs and the tempfile, shutil and random it imports (nothing is written on a
hit)."""


def _loaded(modules: set[str], prefixes: tuple[str, ...]) -> list[str]:
    """The modules of `modules` that are one of `prefixes` or inside one."""
    inside = tuple(prefix + "." for prefix in prefixes)
    return sorted(m for m in modules if m in prefixes or m.startswith(inside))


def _source(tmp_path: Path) -> Path:
    """A clean file: no misspelt name, so no "did you mean" hint (which needs difflib)."""
    source = tmp_path / "lean.mp"
    source.write_text("VAR speed\nMP 1\n  speed = 2000\n  SET_V X, speed\nEND MP\n")
    return source


def test_lint_parses_with_lark_on_a_miss_and_without_it_on_a_hit(tmp_path: Path) -> None:
    """The parser, and lark with it, is imported by the first run only: the second finds
    every statement in the front cache (MPLANG_CACHE, set for the test session)."""
    source = _source(tmp_path)
    first = _modules_after("lint", str(source), cwd=tmp_path)
    assert "lark" in first and "mplang.lang.parser" in first
    # the grammar is read from the package's directory, as the front-end key reads it
    assert _loaded(first, ("importlib.resources", "zipfile")) == []
    again = _modules_after("lint", str(source), cwd=tmp_path)
    assert "mplang.lang.frontcache" in again
    assert _loaded(again, (*NEVER_FOR_A_BUILD, *NEVER_ON_A_HIT, *NEVER_FOR_A_LINT,
                           "mplang.lang.parser",
                           "mplang.lang.tokenizer", "mplang.m8194h.sim", "pymodbus",
                           "pygls")) == []


def test_build_after_a_number_edit_does_not_load_lark(tmp_path: Path) -> None:
    """A line that differs from a cached one in its numbers only is built from the recipe
    the front cache keeps with it (`mplang.lang.recipes`): the parser and lark stay out;
    a line with a new shape brings them back."""
    source = _source(tmp_path)
    _modules_after("build", str(source), "-o", "lean.json", cwd=tmp_path)
    first = (tmp_path / "lean.json").read_text()
    source.write_text(source.read_text().replace("2000", "2500"))
    loaded = _modules_after("build", str(source), "-o", "lean.json", cwd=tmp_path)
    assert "mplang.lang.recipes" in loaded
    assert _loaded(loaded, ("lark", "mplang.lang.parser", "mplang.lang.tokenizer")) == []
    _modules_after("build", "--no-cache", str(source), "-o", "fresh.json", cwd=tmp_path)
    assert (tmp_path / "lean.json").read_text() == (tmp_path / "fresh.json").read_text()
    assert (tmp_path / "lean.json").read_text() != first
    source.write_text(source.read_text().replace("speed = 2500", "speed = 2500 + 1"))
    loaded = _modules_after("build", str(source), "-o", "lean.json", cwd=tmp_path)
    assert "lark" in loaded and "mplang.lang.parser" in loaded


NEVER_FOR_A_CLIENT = ("mplang.m8194h.modbus_server", "mplang.m8194h.ordered",
                      "mplang.m8194h.sim")
"""What a command that only talks to a device never needs: the Modbus server side and the
virtual controller behind it."""


def test_dry_run_flash_loads_the_client_only(tmp_path: Path) -> None:
    """`mpc flash --dry-run` imports the downloader and its Modbus client, never the server
    module (`modbus_server`) nor the virtual controller. The second run hits the front
    cache."""
    source = _source(tmp_path)
    _modules_after("flash", str(source), "--dry-run", cwd=tmp_path)
    loaded = _modules_after("flash", str(source), "--dry-run", cwd=tmp_path)
    assert {"mplang.m8194h.flash.flasher", "mplang.m8194h.modbus", "pymodbus.client"} <= loaded
    assert _loaded(loaded, (*NEVER_FOR_A_BUILD, *NEVER_ON_A_HIT, *NEVER_FOR_A_CLIENT)) == []


def test_status_loads_no_server(tmp_path: Path) -> None:
    """`mpc status` of a device that is not there: the client tries and fails (exit 7)."""
    loaded = _modules_after("status", "--tcp", "127.0.0.1:1", "--timeout", "0.2",
                            cwd=tmp_path)
    assert {"mplang.m8194h.status", "mplang.m8194h.modbus"} <= loaded
    assert _loaded(loaded, (*NEVER_FOR_A_BUILD, *NEVER_FOR_A_CLIENT)) == []


def test_sim_without_monitor_loads_no_monitor(tmp_path: Path) -> None:
    """`mpc sim` serves (so the Modbus server is there) but not the dashboard."""
    source = _source(tmp_path)
    loaded = _modules_after("sim", str(source), "--tcp", "127.0.0.1:0", "--duration", "0.2",
                            cwd=tmp_path)
    assert {"pymodbus.server", "mplang.m8194h.modbus_server", "mplang.m8194h.ordered"} <= loaded
    assert _loaded(loaded, ("mplang.cli.commands.monitor", "mplang.tools.monitor.server",
                            "mplang.m8194h.debugger", "mplang.m8194h.live")) == []


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


def test_the_commands_listed_are_the_modules_pkgutil_finds() -> None:
    """The commands are listed from their package's directory, as pkgutil lists it."""
    import pkgutil

    from mplang.cli import _command_modules, commands
    assert _command_modules() == sorted(info.name for info in
                                        pkgutil.iter_modules(commands.__path__))
