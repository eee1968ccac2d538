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
from mplang.m8194h.compiler import BuildResult, Lowering, compile_paths, compile_sources


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


def _w111(result: BuildResult) -> list[tuple[int, str]]:
    return [(d.span.line, d.message) for d in result.diagnostics if d.code == "W111"]


def test_kept_statements_are_judged_from_the_max_v_they_now_enter(tmp_path: Path) -> None:
    """An edit of a SET_MAX_V inside a program keeps the statements after it (their lines
    unchanged) but enters them with another MAX_V: their warnings are those of a fresh
    build, each time, never the ones kept from the MAX_V before."""
    path = tmp_path / "maxv.mp"
    text = "\n".join(["MP 1 moves", "  SET_V X, 100", "  SET_MAX_V X, 200000",
                      "  SET_A X, 123457", "  SET_V X, 70001", "  SET_D X, 5", "END MP", ""])
    memo, lines = BuildMemo(), StatementCache()
    seen: list[list[tuple[int, str]]] = []
    for max_v in ("200000", "160000", "8000", "200000", "8000"):
        edited = text.replace("200000", max_v)
        kept = compile_paths([path], texts={path: edited}, lines=lines, memo=memo)
        assert _w111(kept) == _w111(compile_paths([path], texts={path: edited}))
        seen.append(_w111(kept))
    assert seen[0] != seen[1] != seen[2] and seen[0] == seen[3] and seen[2] == seen[4]
