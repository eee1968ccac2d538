"""Builds pause the cyclic collector (mplang.lang.heap): it is on again after, and only an
mpc process freezes its start-up objects; a program using mplang as a library keeps its
heap as it was. Each case runs in a fresh interpreter, so no earlier build has frozen
anything."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main

PROGRAM = """
import gc, sys
{imports}
from mplang.m8194h.compiler import compile_source
from mplang.lang.heap import collection_paused
with collection_paused():
    inside = gc.isenabled()
result = compile_source("MP 1\\n  SET_V X, 2000\\nEND MP\\n", "a.mp")
assert result.ok
print(inside, gc.isenabled(), gc.get_freeze_count() > 0)
"""


@pytest.mark.parametrize(("imports", "frozen"), [("", False), ("import mplang.cli", True)],
                         ids=["library", "mpc"])
def test_a_build_pauses_the_collector_and_freezes_only_in_mpc(imports: str,
                                                              frozen: bool) -> None:
    done = subprocess.run([sys.executable, "-c", PROGRAM.format(imports=imports)],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MPLANG_CACHE": "off"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "True", str(frozen)]


START_UP = """
import gc, sys
from mplang.lang import heap
during = []
gc.callbacks.append(lambda phase, info: phase == "start" and heap._starting
                    and during.append(info["generation"]))
from mplang.cli import main
try:
    main(["lint", sys.argv[1]])
except SystemExit:
    pass
print(len(during), gc.isenabled(), gc.get_freeze_count() > 0,
      "mplang.m8194h.compiler" in sys.modules)
"""


def test_mpc_imports_a_command_with_the_collector_off_then_freezes(tmp_path: Path) -> None:
    """No collection while `mpc lint` imports its modules (the compiler among them); the
    collector is on again, start-up frozen, when the command has run."""
    source = tmp_path / "a.mp"
    source.write_text("MP 1\n  SET_V X, 2000\nEND MP\n")
    done = subprocess.run([sys.executable, "-c", START_UP, str(source)], capture_output=True,
                          text=True, timeout=120, env={**os.environ, "MPLANG_CACHE": "off"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["0", "True", "True", "True"]


@pytest.mark.parametrize("args", [["--version"], ["biuld"], ["lint", "--no-such-option"]])
def test_the_collector_is_as_it_was_after_any_command(args: list[str]) -> None:
    """On or off before `mpc` runs in this process, so after, however the command ended
    (a usage error never reaches the command)."""
    was = gc.isenabled()
    try:
        for before in (True, False):
            (gc.enable if before else gc.disable)()
            CliRunner().invoke(main, args)
            assert gc.isenabled() is before
    finally:
        (gc.enable if was else gc.disable)()
