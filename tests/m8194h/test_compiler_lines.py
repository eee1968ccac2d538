"""A build's `sources` (the lines diagnostics and `# mpc: ignore` are read by) are each
file's `str.splitlines()`, whatever line boundaries the text holds."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import compile_paths

PIECES = st.sampled_from(["MP 1 a", "  SET_V X, 5", "END MP", "\n", "\r", "\r\n", "\x0b",
                          "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029", "é",
                          " ", "' note", ""])


@settings(max_examples=60, deadline=None)
@given(st.lists(PIECES, max_size=12))
def test_sources_are_each_files_splitlines(pieces: list[str]) -> None:
    text = "".join(pieces)
    path = Path("lines.mp")
    result = compile_paths([path], texts={path: text, path.resolve(): text})
    assert list(result.sources.values()) == [text.splitlines()]

