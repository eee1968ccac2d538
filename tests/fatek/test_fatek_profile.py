"""The FATEK device data: facts with their manual lines, a readable FUN141 layout, and every
open question answered by a visible choice."""

from __future__ import annotations

from typing import Any

import mplang.fatek as fatek
from mplang.fatek.profile import load


def test_the_documented_sizes_and_flags() -> None:
    profile = load()
    assert (profile.fun140.flag, profile.fun140.words_per_step) == (0xA55A, 9)
    assert (profile.fun147.flag, profile.fun147.words_per_step) == (0xA55C, 15)
    assert profile.fun140.max_steps == 250 and profile.fun140.work_registers == 7
    assert profile.fun147.work_registers == 9


def test_fun141_fills_24_registers_without_gaps() -> None:
    profile = load()
    covered = sorted(spec.offset + k for spec in profile.params for k in range(spec.words))
    assert covered == list(range(profile.fun141_words)) == list(range(24))
    assert [spec.number for spec in profile.params] == list(range(18))
    for spec in profile.params:
        assert spec.min <= spec.default <= spec.max, spec.name
        assert spec.lines.startswith("FB ")


def test_every_choice_cites_the_manual_or_the_m8194h_it_follows() -> None:
    def walk(table: dict[str, Any]) -> list[tuple[dict[str, Any], str]]:
        found = []
        for key, value in table.items():
            if isinstance(value, dict):
                found += walk(value)
            elif key.endswith("_choice"):
                found.append((table, key))
        return found

    choices = walk(load().raw)
    assert len(choices) >= 12
    for table, key in choices:
        assert "FB " in table[key] or "M8194H" in table[key], key


def test_the_family_api_has_the_agreed_names() -> None:
    assert fatek.TARGETS == ("fbs-fun140", "fbs-fun147")
    assert fatek.SUFFIXES == (".fbs",)
    for name in ("check_native", "compile_mp", "run_build", "FamilyBuild", "FamilyRun"):
        assert hasattr(fatek, name)
    assert set(fatek.FORMATS) >= {"listing", "json", "fbs", "table"}


def test_the_mp_command_tables_do_not_overlap() -> None:
    profile = load()
    groups = [set(profile.mp_translated), set(profile.mp_ignored), set(profile.mp_unsupported)]
    assert not (groups[0] & groups[1] or groups[0] & groups[2] or groups[1] & groups[2])
