"""Shared test set-up."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run, so the suite (and CI) is repeatable and
# a failure can be run again; MPLANG_HYPOTHESIS=explore draws fresh ones, for hunting (the
# fuzz tests of tests/test_fuzz_inputs.py take MPLANG_FUZZ=N for the same).
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", database=None)
settings.load_profile(os.environ.get("MPLANG_HYPOTHESIS", "repeatable"))


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
