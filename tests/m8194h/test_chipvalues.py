"""W111 kept between builds (`chipvalues.warn_changed` with the last build's lowerings):
a kept program's warnings are given again only for the rules they were judged by."""

from __future__ import annotations

import copy
from pathlib import Path

from mplang.ir import catalogue as catalogue_module
from mplang.ir.reuse import BuildMemo
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.linecache import StatementCache
from mplang.lang.sources import load_sources
from mplang.m8194h.chipvalues import warn_changed
from mplang.m8194h.compiler import Lowering, compile_sources


def _kept_w111(path: Path, text: str, memo: BuildMemo, lines: StatementCache,
               raw: dict[str, object]) -> list[str]:
    """W111 messages of a build with `memo`, judged again against a profile of `raw`."""
    sink = DiagnosticSink()
    sources = load_sources([path], sink, texts={path: text}, lines=lines)
    lowering = Lowering()
    compile_sources([path], sources, sink, memo=memo, lowering=lowering, encode=False)
    assert lowering.programs is not None
    profile = catalogue_module.load().profile.replace(raw=raw)
    judged = DiagnosticSink()
    warn_changed(lowering.programs, None, profile, judged, memo.lowerings)
    return [d.message for d in judged.items if d.code == "W111"]


def test_kept_w111_follows_the_profiles_parameters(tmp_path: Path) -> None:
    """Rules equal in their numbers but not in which parameters they judge (a profile whose
    `[chip_values.parameters]` no longer names SET_A): the kept program's warnings are
    judged again, not the ones kept for the other parameters."""
    path = tmp_path / "acc.mp"
    text = "MP 1 moves\n  SET_A X, 123457\nEND MP\n"
    raw = catalogue_module.load().profile.raw
    without = copy.deepcopy(raw)
    del without["chip_values"]["parameters"]["SET_A"]
    memo, lines = BuildMemo(), StatementCache()
    judged = _kept_w111(path, text, memo, lines, raw)
    assert judged and "123457" in judged[0]
    assert _kept_w111(path, text, memo, lines, without) == []
    assert _kept_w111(path, text, memo, lines, raw) == judged
    assert _kept_w111(path, text, memo, lines, raw) == judged
