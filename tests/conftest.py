"""Shared test set-up."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def private_state_home(tmp_path_factory: pytest.TempPathFactory,
                       monkeypatch: pytest.MonkeyPatch) -> Path:
    """`mpc flash` keeps its record under $XDG_STATE_HOME: never the real one in tests."""
    state = tmp_path_factory.mktemp("state")
    monkeypatch.setenv("XDG_STATE_HOME", str(state))
    return state


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory: pytest.TempPathFactory,
                  monkeypatch: pytest.MonkeyPatch) -> Path:
    """mpc's caches (docs/cli.md, "Caches") in one directory of this test session, never the
    user's: every test runs with them as a user does, `--no-cache` undone after each."""
    from mplang.lang import caches

    directory = tmp_path_factory.getbasetemp() / "mplang-cache"
    monkeypatch.setenv("MPLANG_CACHE", str(directory))
    caches.turn_off(False)
    return directory
