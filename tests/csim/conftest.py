"""The CSIM tests' shared fixture: a served virtual CSIM in a subprocess."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator

import pytest


@pytest.fixture
def served() -> Iterator[str]:
    """A served virtual CSIM (`mpc sim --target csim --serial pty`): the pty end a host
    opens."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--target", "csim",
                             "--serial", "pty", "--duration", "120"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert "CSIM RS232 on " in line, line
    try:
        yield line.split("CSIM RS232 on ", 1)[1].split()[0]
    finally:
        proc.terminate()
        proc.wait(10)
