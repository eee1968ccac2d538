"""Shared test set-up."""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Generator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run, so the suite (and CI) is repeatable and
# a failure can be run again; MPLANG_HYPOTHESIS=explore draws fresh ones, for hunting (the
# fuzz tests of tests/test_fuzz_inputs.py take MPLANG_FUZZ=N for the same).
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", database=None)
settings.load_profile(os.environ.get("MPLANG_HYPOTHESIS", "repeatable"))

# The programs some tests drive (`make tools` installs them). Outside CI a missing one skips
# those tests, saying so; under CI=true (as .ci/run runs) it fails them: a CI run never
# passes while silently leaving out the tests that need a tool.
TOOLS = ("mbpoll", "gcc", "chromium", "node", "npm", "npx", "bash")
TOOL_NAMED = re.compile(r"\b(" + "|".join(TOOLS) + r")\b")


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("true", "1", "yes")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "needs_tool(name, ...): the test runs these programs; missing, it skips "
                   "(fails under CI=true)")


def pytest_runtest_setup(item: pytest.Item) -> None:
    for mark in item.iter_markers("needs_tool"):
        for tool in mark.args:
            if shutil.which(tool) is None:
                missing = f"needs {tool}, which is not installed (`make tools` installs it)"
                if in_ci():
                    pytest.fail(f"CI=true: {missing}", pytrace=False)
                pytest.skip(missing)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item,
                              call: pytest.CallInfo[None]) -> Generator[None, Any, None]:
    """Under CI=true a skip of a test that needs a tool is a failure."""
    outcome = yield
    report = outcome.get_result()
    if not (report.skipped and in_ci()) or getattr(report, "wasxfail", None) is not None:
        return
    reason = str(report.longrepr[2]) if isinstance(report.longrepr, tuple) else ""
    if any(True for _ in item.iter_markers("needs_tool")) or TOOL_NAMED.search(reason):
        report.outcome = "failed"
        report.longrepr = f"CI=true: a test that needs a tool was skipped: {reason}"


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
