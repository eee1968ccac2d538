"""The register table layout FB documents (A55AH/A55CH, step count, 9 or 15 registers per
step, the 24 FUN141 registers) and nothing it does not: step words stay undefined."""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.fatek import FORMATS, check_native
from mplang.fatek.model import ParamTable
from mplang.fatek.profile import load
from mplang.fatek.render import table_image

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "fatek"


def test_the_jog_table_occupies_what_the_manuals_ladder_implies() -> None:
    # jog forward: SR = R5000, 2 steps -> R5000-R5019; jog backward starts at R5020 (FB 1340)
    build = check_native([SAMPLES / "jog_forward.fbs"])
    text = build.render("table")
    assert "R5000    A55AH" in text and "R5001    0002H" in text
    assert "R5002-R5010" in text and "R5011-R5019" in text
    assert "R5020" not in text
    (table,) = build.programs
    words = table_image(table, load())
    assert len(words) == 2 * 9 + 2 and words[:2] == [0xA55A, 2]
    assert all(word is None for word in words[2:])


def test_fun147_tables_have_their_own_flag_and_fifteen_words_a_step() -> None:
    build = check_native([SAMPLES / "fun147_format_example.fbs"])
    (table,) = build.programs
    words = table_image(table, load())
    assert words[:2] == [0xA55C, 3] and len(words) == 3 * 15 + 2
    assert "SR+2-SR+16" in build.render("table")


def test_fun141_tables_are_written_word_by_word() -> None:
    build = check_native([SAMPLES / "example3_drvz_md2.fbs"])
    params = next(t for t in build.programs if isinstance(t, ParamTable))
    words = table_image(params, load())
    assert len(words) == 24
    assert words[0] == 1 and words[1] == 2000  # defaults: motor units, 2000 Ps/rev
    assert words[5:7] == [460_000 & 0xFFFF, 460_000 >> 16]  # DR: low word first
    assert words[9] == 1000 and words[12] == 0x0100
    assert words[19:21] == [0xFF00, 0x0804]  # parameter 15: DOG X0, PG0 X4, CLR Y8
    assert words[21:23] == [100, 0] and words[23] == 10


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_renders(fmt: str) -> None:
    text = check_native([SAMPLES / "format_example.fbs"]).render(fmt)
    assert "format_example" in text


def test_an_unknown_format_is_refused() -> None:
    with pytest.raises(ValueError, match="listing"):
        check_native([SAMPLES / "jog_forward.fbs"]).render("hex")


def test_the_listing_shows_registers_and_source_lines() -> None:
    text = check_native([SAMPLES / "jog_forward.fbs"]).render("listing")
    assert "R5002-R5010" in text and "jog_forward.fbs:5" in text and "999999" in text
