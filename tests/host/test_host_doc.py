"""The complete host program of docs/host.md runs as documented: against `mpc sim` holding
the cell of samples/host/, from the repository's root, it prints the build it checked, what
the tour wrote, the parts and the X axis, and the line where `rate` failed."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

from monitorproc import stop
from simproc import start_sim

from mplang.cli.common import EXIT_OK

ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```python\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def example() -> str:
    """The python block under "A complete host program"."""
    text = (ROOT / "docs" / "host.md").read_text(encoding="utf-8")
    section = text.split("## A complete host program", 1)[1]
    found = FENCE.search(section)
    assert found is not None, "docs/host.md: no python block under 'A complete host program'"
    return found.group(1)


def test_the_documented_host_program_runs_against_mpc_sim(tmp_path: Path) -> None:
    program = tmp_path / "host_example.py"
    program.write_text(example())
    # a copy, laid out as in the repository: the flash writes the project's flash record
    cell = tmp_path / "samples" / "host"
    shutil.copytree(ROOT / "samples" / "host", cell, ignore=shutil.ignore_patterns(".mpc"))
    proc, port = start_sim("--duration", "120")
    try:
        flashed = subprocess.run([sys.executable, "-m", "mplang", "flash", "--tcp", str(port)],
                                 capture_output=True, text=True, timeout=60, cwd=cell)
        assert flashed.returncode == EXIT_OK, flashed.stderr
        build = json.loads(subprocess.run(
            [sys.executable, "-m", "mplang", "export"], capture_output=True, text=True,
            timeout=60, cwd=cell).stdout)["build_id"]
        ran = subprocess.run([sys.executable, str(program), f"127.0.0.1:{port}"],
                             capture_output=True, text=True, timeout=120, cwd=tmp_path)
    finally:
        stop(proc)
    assert ran.returncode == 0, ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0] == f"the cell holds build {build}"
    assert re.fullmatch(r"tour took \d+ ms and wrote \{'batch': 0, 'parts': 3\}", lines[1])
    assert lines[2] == "parts: 3, X at 3000 (stopped)"
    assert lines[3] == "rate failed at samples/host/cell.mp:18 with R103"
    assert len(lines) == 4


def test_the_documented_host_program_refuses_another_build(tmp_path: Path) -> None:
    program = tmp_path / "host_example.py"
    program.write_text(example())
    proc, port = start_sim("--duration", "60")  # a device with nothing flashed
    try:
        ran = subprocess.run([sys.executable, str(program), f"127.0.0.1:{port}"],
                             capture_output=True, text=True, timeout=120, cwd=ROOT)
    finally:
        stop(proc)
    assert ran.returncode == 1 and ran.stdout == ""
    assert ran.stderr.startswith("not the cell's build: the device holds no build manifest")
