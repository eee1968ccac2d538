"""The user's state and cache directories (mplang.lang.userdirs): what platformdirs gives on
this platform, and the XDG variables honoured when absolute."""

from __future__ import annotations

from pathlib import Path

import platformdirs
import pytest

from mplang.lang import userdirs


def test_the_platform_directories_are_platformdirs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("XDG_STATE_HOME", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert userdirs.state_home() == Path(platformdirs.user_state_dir())
    assert userdirs.cache_home() == Path(platformdirs.user_cache_dir())


def test_an_absolute_xdg_variable_is_honoured_and_a_relative_one_not(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "c"))
    monkeypatch.setenv("XDG_STATE_HOME", "relative/state")
    assert userdirs.cache_home() == tmp_path / "c"
    monkeypatch.delenv("XDG_STATE_HOME")
    expected = Path(platformdirs.user_state_dir())
    monkeypatch.setenv("XDG_STATE_HOME", "relative/state")
    assert userdirs.state_home() == expected
