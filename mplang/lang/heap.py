"""Python's cyclic garbage collector around a build.

A build allocates some hundred thousand objects (statements, spans, macro lines, frames)
that live until it ends, and none of them in a reference cycle (tests/m8194h/
test_compiler_memory.py keeps it so): reference counting frees them all. The collector
would only walk them, and everything already alive, over and over while they are made
(16-18 ms of a full-device build, more in a long-running language server whose heap holds
earlier analyses). So a build runs with the collector off, and in an `mpc` process the
first build freezes what start-up made (modules, the catalogue, lark's tables), which no
later collection then walks. A program that only uses mplang as a library (the host API)
gets the pause alone: freezing its objects would keep any of them that later became cyclic
garbage for good.
"""

from __future__ import annotations

import gc
import sys
from collections.abc import Iterator
from contextlib import contextmanager

_frozen = False


@contextmanager
def collection_paused() -> Iterator[None]:
    """Run the body with the cyclic collector off (as it was after); nested uses are one."""
    global _frozen
    if not _frozen and "mplang.cli" in sys.modules:  # the mpc command, not a library user
        _frozen = True
        gc.freeze()
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
