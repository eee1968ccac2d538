"""The dashboard's web server is the `monitor` extra (issue 15 item 8, as `lsp` and `plot`):
`mpc monitor` and `mpc sim --monitor` without aiohttp name the extra and exit 15, and no
other command needs it."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

from mplang.cli import EXIT_MISSING_EXTRA, EXIT_OK

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "samples" / "home_then_square.mp"
WITHOUT_AIOHTTP = ("import sys\nsys.modules['aiohttp'] = None\n"
                   "from mplang.cli import main\nmain(sys.argv[1:], prog_name='mpc')\n")
"""`mpc ARGS` in a Python where aiohttp cannot be imported, as in an install without it."""


def without_aiohttp(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", WITHOUT_AIOHTTP, *args], capture_output=True,
                          text=True, check=False, cwd=ROOT, stdin=subprocess.DEVNULL,
                          timeout=120)


def test_mpc_monitor_and_sim_monitor_without_aiohttp_name_the_extra() -> None:
    for args, command in ((["monitor", "--tcp", "127.0.0.1:1"], "mpc monitor"),
                          (["sim", "--tcp", "0", "--monitor", "0", "--duration", "0"],
                           "mpc sim --monitor")):
        proc = without_aiohttp(*args)
        assert proc.returncode == EXIT_MISSING_EXTRA, (args, proc.stderr)
        assert f"{command} needs aiohttp" in proc.stderr
        assert "the monitor extra of mplang" in proc.stderr
        assert "pip install '.[monitor]'" in proc.stderr
        assert "Traceback" not in proc.stderr


def test_only_the_dashboard_needs_aiohttp(tmp_path: Path) -> None:
    for args in (["lint", str(SAMPLE)], ["run", str(SAMPLE), "--json"], ["--help"],
                 ["sim", "--tcp", "0", "--duration", "0"]):
        proc = without_aiohttp(*args)
        assert proc.returncode == EXIT_OK, (args, proc.stderr)


def test_pyproject_monitor_extra_in_dev_not_in_base() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith("aiohttp") for d in meta["dependencies"])
    assert [d for d in meta["optional-dependencies"]["monitor"] if d.startswith("aiohttp")]
