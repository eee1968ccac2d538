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

Start-up is the same: `mpc` imports a command's modules (a few hundred, the compiler's
among them), which allocate some hundred thousand objects that live as long as the process,
and the collector walked them over and over while they were made (a tenth of a lint's
start). So `mpc` imports a command's modules with the collector off (`starting`), then
freezes what they made and turns it on again (`started`) before the command runs.
"""

from __future__ import annotations

import gc
import sys
from collections.abc import Iterator
from contextlib import contextmanager

_frozen: set[str] = set()
"""The moments (start-up, the first build) whose objects this `mpc` process has frozen."""
_starting = False


def in_mpc() -> bool:
    """This process runs the `mpc` command (its CLI is imported), not a program using mplang
    as a library: only `mpc` freezes its heap."""
    return "mplang.cli" in sys.modules


def _freeze_once(moment: str) -> None:
    """Freeze what this `mpc` process holds now, once per `moment` (a test process runs
    many commands: only the first of each is frozen, as in one `mpc` run)."""
    if moment not in _frozen:
        _frozen.add(moment)
        gc.freeze()


def starting() -> bool:
    """`mpc` begins: the collector off while the command's modules are imported. True when
    it was on (and `finished` must turn it on again)."""
    global _starting
    if not gc.isenabled():
        return False
    gc.disable()
    _starting = True
    return True


def started() -> None:
    """The command's modules are imported: freeze what start-up made and turn the collector
    on again, before the command runs (a server lives long and makes cycles)."""
    global _starting
    if _starting:
        _starting = False
        _freeze_once("start-up")
        gc.enable()


def finished(was_on: bool) -> None:
    """`mpc` ends (the command ran, or never started: a usage error): the collector as it
    was before `starting`, whatever happened in between."""
    global _starting
    _starting = False
    if was_on:
        gc.enable()


@contextmanager
def collection_paused() -> Iterator[None]:
    """Run the body with the cyclic collector off (as it was after); nested uses are one."""
    if in_mpc():
        _freeze_once("build")
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
