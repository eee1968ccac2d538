"""Under CI=true no test that needs a tool (mbpoll, gcc, chromium, node/npm) may skip: the
hooks of tests/conftest.py turn such a skip into a failure. Run on a small suite of its own
in a subprocess, with and without CI=true."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

CONFTEST = Path(__file__).resolve().parent / "conftest.py"
SUITE = '''
import pytest

@pytest.mark.needs_tool("mpc-no-such-tool")
def test_marked():
    pass

def test_skipped_naming_a_tool():
    pytest.skip("mbpoll is not installed")

def test_skipped_for_another_reason():
    pytest.skip("not on this platform")

@pytest.mark.needs_tool("python3")
def test_present_tool_runs():
    pass
'''


def run(tmp_path: Path, ci: str | None) -> subprocess.CompletedProcess[str]:
    shutil.copy(CONFTEST, tmp_path / "conftest.py")
    (tmp_path / "test_suite.py").write_text(SUITE)
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    if ci is not None:
        env["CI"] = ci
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rfEs", "-p",
                           "no:cacheprovider", str(tmp_path)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)


def test_outside_ci_a_missing_tool_skips_saying_so(tmp_path: Path) -> None:
    result = run(tmp_path, None)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 passed, 3 skipped" in result.stdout, result.stdout
    assert "needs mpc-no-such-tool, which is not installed (`make tools`" in result.stdout


def test_under_ci_a_skip_for_a_tool_fails_the_run(tmp_path: Path) -> None:
    result = run(tmp_path, "true")
    assert result.returncode == 1, result.stdout + result.stderr
    assert "1 failed, 1 passed, 1 skipped, 1 error" in result.stdout, result.stdout
    assert "ERROR test_suite.py::test_marked - Failed: CI=true: needs mpc-no-such-tool" \
        in result.stdout
    assert "FAILED test_suite.py::test_skipped_naming_a_tool" in result.stdout
    assert "CI=true: a test that needs a tool was skipped" in result.stdout
