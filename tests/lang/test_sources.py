"""Loading sources and includes: paths no file system accepts are diagnostics, not crashes."""

from __future__ import annotations

from mplang.m8194h.compiler import compile_source


def test_an_include_path_with_a_nul_character_is_an_e102() -> None:
    result = compile_source('INCLUDE "a\0b.mp"\nMP 1 a\n    VAR1 = 1\nEND MP\n')
    assert [(d.code, d.span.line) for d in result.diagnostics] == [("E102", 1)]
    assert "NUL" in result.diagnostics[0].message
