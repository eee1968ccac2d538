"""Where the manual re-read runs, skips or fails: in a clone without the manual it skips
(the catalogue checks ran from tests/data), under CI=true it fails, since CI's clone has the
manuals beside it. Run in a subprocess with MPLANG_MANUALS naming an empty directory, so the
result does not depend on whether this clone has the manuals."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TEST = "tests/stdlib/test_catalogue.py::test_the_stored_tables_are_the_manual_s"
REPO = Path(__file__).resolve().parents[2]


def run(manuals: Path, ci: str | None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["MPLANG_MANUALS"] = str(manuals)
    if ci is not None:
        env["CI"] = ci
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rfEs", "-p",
                           "no:cacheprovider", TEST], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=120)


def test_without_the_manual_the_re_read_skips_saying_where_it_looked(tmp_path: Path) -> None:
    result = run(tmp_path, None)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "SKIPPED [1] tests/stdlib/test_catalogue.py:" in result.stdout, result.stdout
    assert f"the manual is not at {tmp_path / '001_404865bff90dda3e.txt'} " in result.stdout
    assert "the checks above ran from rs-manual-tables.json" in result.stdout


def test_under_ci_a_missing_manual_fails_the_run(tmp_path: Path) -> None:
    result = run(tmp_path, "true")
    assert result.returncode == 1, result.stdout + result.stderr
    assert f"FAILED {TEST} - Failed: CI=true: the manual is not at" in result.stdout, \
        result.stdout
    assert "SKIPPED" not in result.stdout
