"""The device manifest (mplang.m8194h.flash.manifest): checks that mutation testing
(`make mutate`, docs/testing.md) found unheld: range boundaries and their messages, and the
JSON form's field names."""

from __future__ import annotations

import pytest
from test_flash_incremental import JOB, image_of

from mplang.m8194h.flash import manifest as mf


def test_range_boundaries_and_their_messages() -> None:
    """A one-MD range is too small, not backwards; the smallest range and the last long MD
    are accepted, MD1024 is not."""
    with pytest.raises(ValueError, match=r"^MD5-MD5: a manifest needs at least 8 MD$"):
        mf.parse_range("MD5-MD5")
    assert mf.parse_range("MD0-MD7") == mf.MdRange(0, 7)
    assert str(mf.parse_range("MD1016-MD1023")) == "MD1016-MD1023"
    with pytest.raises(ValueError, match=r"^MD1017-MD1024: the manifest goes in the long"):
        mf.parse_range("MD1017-MD1024")


def test_the_json_form_names_every_field() -> None:
    """`mpc status --json` and the flash report: the field names are the interface."""
    manifest = mf.manifest_of(image_of(JOB), (110, 1, 0, 0, 0), 1700000000)
    data = mf.to_json(manifest)
    assert list(data) == ["format_version", "build_id", "tool_version", "flashed_at",
                          "word_order", "download_status", "programs"]
    assert data["format_version"] == 1 and data["flashed_at"] == 1700000000
    assert data["download_status"] == [110, 1, 0, 0, 0]
    assert data["programs"] == [{"slot": p.slot_label, "name": p.name, "hash": p.hash}
                                for p in manifest.programs]
    assert data["programs"] and data["build_id"] == manifest.build_id
    assert mf.decode(mf.encode(manifest)) == manifest


def test_seven_md_are_one_too_few_and_floats_are_named() -> None:
    with pytest.raises(ValueError, match=r"^MD0-MD6: a manifest needs at least 8 MD$"):
        mf.parse_range("MD0-MD6")
    with pytest.raises(ValueError) as caught:
        mf.parse_range("MD1000-MD1100")
    assert str(caught.value).endswith(
        "(MD1024-MD2047 are floats, whose bit patterns a device may change)")


def test_a_long_name_is_cut_at_a_character_boundary() -> None:
    """Program names keep at most 12 bytes of UTF-8, never half a character: six 'ä' (two
    bytes each) fill the 12; after an 'x', the sixth 'ä' would end at byte 13, so five stay;
    '€' takes three bytes, so four fit."""
    for name, kept in (("ääääääää", "ääääää"), ("xääääääää", "xäääää"),
                       ("abcdefghijklmn", "abcdefghijkl"), ("€€€€€", "€€€€")):
        program = mf.ManifestProgram("mp", 1, "0" * 16, name)
        manifest = mf.Manifest("b", "t", 0, 0, (0, 0, 0, 0, 0), (program,))
        assert mf.decode(mf.encode(manifest)).programs[0].name == kept, name
