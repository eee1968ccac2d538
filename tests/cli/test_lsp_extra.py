"""The language server's dependencies are the `lsp` extra (issue 15 item 8): `mpc lsp`
without pygls names the extra and exits 15, and no other command needs it."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

from mplang.cli import EXIT_MISSING_EXTRA, EXIT_OK

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "samples" / "home_then_square.mp"
WITHOUT_PYGLS = ("import sys\nsys.modules['pygls'] = None\nsys.modules['lsprotocol'] = None\n"
                 "from mplang.cli import main\nmain(sys.argv[1:], prog_name='mpc')\n")
"""`mpc ARGS` in a Python where pygls cannot be imported, as in an install without the extra."""


def without_pygls(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", WITHOUT_PYGLS, *args], capture_output=True,
                          text=True, check=False, cwd=ROOT, stdin=subprocess.PIPE,
                          timeout=120)


def test_mpc_lsp_without_pygls_names_the_extra() -> None:
    proc = without_pygls("lsp", "--stdio")
    assert proc.returncode == EXIT_MISSING_EXTRA
    assert "mpc lsp needs pygls" in proc.stderr
    assert "the lsp extra of mplang" in proc.stderr
    assert "pip install '.[lsp]'" in proc.stderr and "Traceback" not in proc.stderr


def test_only_mpc_lsp_needs_pygls(tmp_path: Path) -> None:
    for args in (["lint", str(SAMPLE)], ["build", str(SAMPLE), "-o", str(tmp_path / "i.json")],
                 ["fmt", "--check", str(SAMPLE)], ["run", str(SAMPLE), "--json"], ["--help"]):
        proc = without_pygls(*args)
        assert proc.returncode == EXIT_OK, (args, proc.stderr)


def test_pyproject_lsp_extra_in_dev_not_in_base() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith(("pygls", "lsprotocol")) for d in meta["dependencies"])
    assert [d for d in meta["optional-dependencies"]["lsp"] if d.startswith("pygls")]
