"""W103 (read-before-write) speaks the source's words: an ALIAS is named as written, with
the device's number beside it (issue 14, item 2)."""

from __future__ import annotations

from mplang.m8194h.compiler import compile_source


def w103_messages(source: str) -> list[str]:
    build = compile_source(source)
    return [d.message for d in build.diagnostics if d.code == "W103"]


def test_w103_names_an_alias_with_its_number() -> None:
    source = "ALIAS hits = VAR30\nMP 1\n    hits = hits + 1\nEND MP\n"
    assert w103_messages(source) == ["hits (VAR30) is read before this program writes it"]


def test_w103_names_an_alias_in_a_command_argument_and_a_condition() -> None:
    source = ("ALIAS dist = VAR31\nALIAS limit = VAR32\nMP 1\n    FIXED_MOVE X, dist\n"
              "    IF (limit) > 0\n        VAR1 = 0\n    END IF\nEND MP\n")
    assert w103_messages(source) == ["dist (VAR31) is read before this program writes it",
                                     "limit (VAR32) is read before this program writes it"]


def test_w103_keeps_the_device_name_where_the_source_writes_it() -> None:
    source = "ALIAS hits = VAR30\nMP 1\n    VAR2 = VAR30 + 1\nEND MP\n"
    assert w103_messages(source) == ["VAR30 is read before this program writes it"]
