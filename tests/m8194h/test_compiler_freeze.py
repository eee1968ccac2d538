"""The first build of an `mpc` process without a memo is frozen with it (`compiler.
_freeze_first_build`): the collection after it walks none of its objects. Later builds,
builds with a memo (the language server) and a program using mplang as a library are not.
A library's build is moved to the collector's oldest generation instead (`_promote_build`).
Each case runs in a fresh interpreter, so no earlier build has frozen anything."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROGRAM = """
import gc
{imports}
from mplang.m8194h.compiler import BuildMemo, compile_source, compile_paths
from pathlib import Path
text = "MP 1\\n  SET_V X, 2000\\nEND MP\\n"
{memo_build}
start = gc.get_freeze_count()
first = compile_source(text, "a.mp")
ids = {{id(o) for o in gc.get_objects()}}
oldest = {{id(o) for o in gc.get_objects(generation=2)}}
program = first.programs[0]
print(gc.get_freeze_count() > start, id(program) in ids, id(program.lines) in ids,
      id(program) in oldest)
count = gc.get_freeze_count()
second = compile_source(text, "b.mp")
print(gc.get_freeze_count() == count, gc.isenabled())
"""


@pytest.mark.parametrize(("imports", "memo_first", "frozen"), [
    ("", False, False), ("import mplang.cli", False, True), ("import mplang.cli", True, True)],
    ids=["library", "mpc", "mpc-after-a-memo-build"])
def test_the_first_build_of_mpc_is_frozen(imports: str, memo_first: bool,
                                          frozen: bool) -> None:
    memo_build = 'compile_paths([Path("m.mp")], texts={Path("m.mp"): text}, memo=BuildMemo())' \
        if memo_first else ""
    done = subprocess.run([sys.executable, "-c", PROGRAM.format(imports=imports,
                                                                memo_build=memo_build)],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MPLANG_CACHE": "off"})
    assert done.returncode == 0, done.stderr
    lines = done.stdout.split("\n")
    grew, program_seen, lines_seen, promoted = lines[0].split()
    assert grew == str(frozen)
    # frozen objects are no longer among those the collector walks
    assert program_seen == lines_seen == str(not frozen)
    # a library's build is moved to the oldest generation, not walked by the collection
    # that follows it, and stays where a full collection finds it (`_promote_build`)
    assert promoted == str(not frozen)
    assert lines[1].split() == ["True", "True"]
