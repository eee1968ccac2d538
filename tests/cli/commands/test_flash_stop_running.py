"""`mpc flash --stop-running` (issue 19 item 2): a program running in the device makes the
flash refuse before anything is written; with the option the flash stops it (MP_TERMINATE)
and goes on. Against `mpc sim` in a subprocess, the program started by an independent
Modbus client (mbpoll writing holding register 8, 4.16.3)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from simproc import start_sim

from mplang.cli.common import EXIT_OK, EXIT_REJECTED, EXIT_USAGE

WAITER = "MP 1 waiter\n    TIMER 100000\nEND MP\n"
JOB = "MP 5 job\n    VAR1 = 7\nEND MP\n"
MBPOLL = shutil.which("mbpoll")


def mpc(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=120)


@pytest.mark.needs_tool("mbpoll")
def test_a_running_program_is_stopped_only_with_stop_running(tmp_path: Path) -> None:
    waiter, job = tmp_path / "waiter.mp", tmp_path / "job.mp"
    waiter.write_text(WAITER)
    job.write_text(JOB)
    proc, port = start_sim(str(waiter), "--duration", "60")
    try:
        assert MBPOLL is not None
        called = subprocess.run([MBPOLL, "-1", "-0", "-m", "tcp", "-p", str(port), "-a", "1",
                                 "-t", "4", "-r", "8", "127.0.0.1", "1"],
                                capture_output=True, text=True, timeout=20)
        assert called.returncode == 0, called.stdout
        record = ["--record", str(tmp_path / "record.json")]
        refused = mpc("flash", str(job), "--tcp", f"127.0.0.1:{port}", *record)
        assert refused.returncode == EXIT_REJECTED, refused.stderr
        assert "MP1 is running" in refused.stderr and "--stop-running" in refused.stderr
        done = mpc("flash", str(job), "--tcp", f"127.0.0.1:{port}", "--stop-running", *record)
        assert done.returncode == EXIT_OK, done.stderr
        assert "1 program(s) written and verified" in done.stderr
    finally:
        proc.terminate()
        proc.wait(10)


def test_stop_running_is_refused_for_a_family_without_it(tmp_path: Path) -> None:
    listing = tmp_path / "p.csim"
    listing.write_text("MA 100\n")
    result = mpc("flash", str(listing), "--serial", "/dev/null", "--stop-running")
    assert result.returncode == EXIT_USAGE
    assert "--stop-running: M8194H option" in " ".join(result.stderr.split())
