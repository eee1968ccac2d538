"""Builds pause the cyclic collector (mplang.lang.heap): it is on again after, and only an
mpc process freezes its start-up objects; a program using mplang as a library keeps its
heap as it was. Each case runs in a fresh interpreter, so no earlier build has frozen
anything."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

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
