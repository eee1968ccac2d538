"""Where the manual re-read runs, skips or fails: without the manual at the default place
beside the repository it skips (the catalogue checks ran from tests/data), with a directory
named by MPLANG_MANUALS that does not hold it, it fails. Run in process with the manual's
location pointed at an empty directory, so the result does not depend on whether this clone
has the manuals."""

from __future__ import annotations

from pathlib import Path

import pytest
import rs_manual
from test_catalogue import test_the_stored_tables_are_the_manual_s as re_read


def test_without_the_manual_beside_the_repository_the_re_read_skips_saying_where_it_looked(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MPLANG_MANUALS", raising=False)
    monkeypatch.setenv("CI", "true")  # a CI run without the manuals beside it is supported
    monkeypatch.setattr(rs_manual, "MANUAL", tmp_path / "001_404865bff90dda3e.txt")
    with pytest.raises(pytest.skip.Exception) as skipped:
        re_read()
    assert f"the manual is not at {tmp_path / '001_404865bff90dda3e.txt'} " in str(skipped.value)
    assert "the checks above ran from rs-manual-tables.json" in str(skipped.value)


def test_a_named_directory_without_the_manual_fails_the_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MPLANG_MANUALS", str(tmp_path))
    monkeypatch.setattr(rs_manual, "MANUAL", tmp_path / "001_404865bff90dda3e.txt")
    with pytest.raises(pytest.fail.Exception) as failed:
        re_read()
    assert str(failed.value).startswith("MPLANG_MANUALS is set: the manual is not at "), \
        str(failed.value)
