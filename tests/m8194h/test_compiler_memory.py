"""A build makes no reference cycles, so memory stays flat without the cyclic collector
(builds run with it paused: mplang.lang.heap). Counted in objects the collector tracks,
never timed: repeated builds and editor analyses of the same text, with syntax errors
and link errors among them, leave nothing behind."""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from mplang.lang import caches
from mplang.m8194h.compiler import compile_source
from mplang.tools.lsp.analysis import analyse

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "samples" / "full_mp156.mp"
BROKEN = ("MP 2\n  X = = 1\n  FOO 999999999999999999999\n  CALL MP2\n  SET_V X, ((1))\n"
          "  é = 3\nIF\nEND MP\n")


@pytest.fixture
def collector_off() -> Iterator[None]:
    caches.turn_off(True)
    try:
        yield
    finally:
        gc.enable()
        caches.turn_off(False)


def _left_behind(build: Callable[[], object]) -> tuple[int, int]:
    """Objects tracked more after three builds than before them, and the cyclic garbage
    the collector then finds. Two builds first, with the collector on: what the first
    build of a process makes once (lark's tables, when no cache holds them) stays or goes."""
    build()
    build()
    gc.collect()
    gc.disable()
    before = len(gc.get_objects())
    for _ in range(3):
        build()
    grown = len(gc.get_objects()) - before
    return grown, gc.collect()


@pytest.mark.parametrize("extra", ["", BROKEN], ids=["clean", "with-errors"])
def test_repeated_builds_keep_memory_flat(collector_off: None, extra: str) -> None:
    text = SAMPLE.read_text(encoding="utf-8") + extra
    assert _left_behind(lambda: compile_source(text, "memory.mp")) == (0, 0)


@pytest.mark.parametrize("extra", ["", BROKEN], ids=["clean", "with-errors"])
def test_repeated_analyses_of_one_document_keep_memory_flat(collector_off: None,
                                                            extra: str) -> None:
    text = SAMPLE.read_text(encoding="utf-8") + extra
    assert _left_behind(lambda: analyse(SAMPLE, text)) == (0, 0)
