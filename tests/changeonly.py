"""The virtual M8194H's planning on change only switched on or off for a test
(`profiles.CHANGE_ONLY`): off, the model plans everything afresh and the interpreter goes
back to `advance` after every motion line and wait, the reference its shortcuts must match."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim import profiles
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import preload


@contextmanager
def planning(change_only: bool) -> Iterator[None]:
    """Plan on change only (the default) or afresh everywhere, and start with no memo."""
    saved = profiles.CHANGE_ONLY
    profiles.CHANGE_ONLY = change_only
    profiles._P2P.clear()
    try:
        yield
    finally:
        profiles.CHANGE_ONLY = saved


def called(source: str) -> VirtualController:
    """A virtual controller holding `source` compiled (it must compile), MP156 called."""
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController(word_order=build.word_order)
    preload(vc, build)
    vc.call(156)
    return vc
