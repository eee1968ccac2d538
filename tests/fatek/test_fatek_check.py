"""Checking listings: the manual's listings are clean, tables see each other, and bad input of
any kind becomes a diagnostic (tests/data/checks/E6*.fbs hold one failing input per rule)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.fatek import check_native
from mplang.fatek.build import FamilyBuild
from mplang.fatek.model import PositioningTable

SAMPLES = sorted((Path(__file__).resolve().parents[2] / "samples" / "fatek").glob("*.fbs"))


def check(text: str, target: str | None = None, name: str = "t.fbs") -> FamilyBuild:
    path = Path(name)
    return check_native([path], target, texts={path: text})


def codes(build: FamilyBuild) -> list[tuple[str, int]]:
    return [(d.code, d.span.line) for d in build.diagnostics]


@pytest.mark.parametrize("path", SAMPLES, ids=[p.name for p in SAMPLES])
def test_every_manual_listing_checks_clean(path: Path) -> None:
    build = check_native([path])
    assert build.ok and build.diagnostics == [], [d.render() for d in build.diagnostics]


def test_the_manuals_examples_reuse_registers_so_they_are_separate_builds() -> None:
    build = check_native(SAMPLES)
    assert {d.code for d in build.diagnostics} >= {"E617"}  # e.g. R5000 in examples 4 and jog


def test_a_listing_without_header_takes_the_target_or_its_content() -> None:
    drive = "001 SPD 5\n DRV ADR,+,1,Ps\n MEND\n"
    line = "001 SPD 5\n LIN ADR,1,,,,Ps\n MEND\n"
    table = check(drive).programs[0]
    assert isinstance(table, PositioningTable) and table.fun == 140 and table.name == "t"
    assert isinstance(check(line).programs[0], PositioningTable)
    assert check(line).programs[0].fun == 147  # type: ignore[union-attr]
    assert codes(check(drive, "fbs-fun147")) == [("E614", 2)]


def test_a_table_of_the_other_function_is_refused_for_a_target() -> None:
    build = check("TABLE a FUN140 Ps0\n001 SPD 5\n DRV ADR,+,1,Ps\n MEND\n", "fbs-fun147")
    assert codes(build) == [("E616", 1)]


def test_unknown_targets_are_a_programming_error() -> None:
    with pytest.raises(ValueError, match="fbs-fun140"):
        check("", "fbs-fun999")


def test_unreadable_files_are_diagnostics(tmp_path: Path) -> None:
    missing = tmp_path / "missing.fbs"
    binary = tmp_path / "binary.fbs"
    binary.write_bytes(b"\xff\xfe\x00SPD")
    build = check_native([missing, binary])
    assert sorted(d.code for d in build.diagnostics) == ["E102", "E105"]
    assert not build.ok


def test_warnings_can_be_silenced_on_their_line() -> None:
    text = "001 SPD 5\n DRV ADR,+,1,Ps\n GOTO NEXT ; mpc: ignore[W601]\n" \
           "002 SPD 5\n DRV ADR,+,1,Ps\n MEND\n"
    assert check(text).diagnostics == []


def test_drvz_with_a_complete_setup_is_clean() -> None:
    text = ("TABLE p FUN141 Ps0\nP15 = 0804FF00H\nP17 = 3\n"
            "TABLE h FUN140 Ps0\n001 SPD 5000\n DRVZ MD2\n MEND\n")
    assert check(text).diagnostics == []


def test_a_clr_output_beyond_y23_is_reported() -> None:
    text = "TABLE p FUN141 Ps0\nP15 = 18FFFF00H\nTABLE h FUN140 Ps0\n001 SPD 5\n DRVZ MD0\n MEND\n"
    build = check(text)
    assert codes(build) == [("E619", 5)]
    assert "CLR" in build.diagnostics[0].message


def test_mechanical_units_check_the_frequency_limit() -> None:
    # 153000 cm/min with 2000 Ps/rev and 1 um/rev is far above 921600 Ps/s (FB 1578)
    text = "TABLE p FUN141 Ps0\nP0 = 0\nP2 = 1\nP4 = 153000\n"
    assert codes(check(text)) == [("E618", 4)]


def test_the_closing_drv_of_a_chain_may_not_be_abs() -> None:
    text = "001 SPD 5\n DRVC ADR,+,10,Ps\n GOTO NEXT\n002 SPD 5\n DRV ABS,,10,Ps\n MEND\n"
    assert codes(check(text)) == [("E609", 5)]


def test_sim_lines_are_checked_too() -> None:
    assert codes(check("SIM X300 ON AT 1\nSIM R4500 = 1\n")) == [("E607", 1), ("E606", 2)]
