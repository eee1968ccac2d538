"""The user's state and cache directories (mplang.lang.userdirs): what platformdirs gives on
this platform, and the XDG variables honoured when absolute."""

from __future__ import annotations

import os
import subprocess
import sys
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


def test_an_absolute_xdg_variable_needs_no_platformdirs(tmp_path: Path) -> None:
    """platformdirs (and tempfile, which it imports) is loaded when a variable does not
    answer only: a fresh interpreter that asks with both variables set loads neither."""
    script = ("import sys\nfrom mplang.lang import userdirs\n"
              "print(userdirs.cache_home(), userdirs.state_home())\n"
              "print(sorted(m for m in ('platformdirs', 'tempfile') if m in sys.modules))\n")
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "c"),
           "XDG_STATE_HOME": str(tmp_path / "s")}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env=env, check=True)
    assert done.stdout.splitlines() == [f"{tmp_path / 'c'} {tmp_path / 's'}", "[]"]
