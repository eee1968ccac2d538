"""mplang.family.stopsignals: Ctrl-C and SIGTERM stop an asyncio command with the loop's
signal handlers (Unix) and without them (Windows' loops, reproduced by the Windows-like
Python of tests/data/windowslike), and the handlers before it come back after it: Python's
default, an ignored signal (a background job's SIGINT) or a host program's own handler."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

WINDOWS_LIKE = Path(__file__).resolve().parents[1] / "data" / "windowslike"

SCRIPT = """
import asyncio, os, signal
from mplang.family.stopsignals import on_stop_signals

async def main(sig):
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    with on_stop_signals(stop.set):
        loop.call_later(0.05, os.kill, os.getpid(), sig)
        await asyncio.wait_for(stop.wait(), 60)
    return stop.is_set()

def own(number, frame):
    pass

for sig in (signal.SIGINT, signal.SIGTERM):
    for before in (signal.getsignal(sig), signal.SIG_IGN, own):
        signal.signal(sig, before)
        stopped = asyncio.run(main(sig))
        print(sig.name, "stopped" if stopped else "running", signal.getsignal(sig) is before)
"""


@pytest.mark.parametrize("windows_like", [False, True], ids=["unix-loop", "windows-like"])
def test_ctrl_c_and_sigterm_stop_and_leave_the_handlers_as_they_were(windows_like: bool
                                                                     ) -> None:
    env = dict(os.environ)
    if windows_like:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(WINDOWS_LIKE),
                                                          env.get("PYTHONPATH")]))
    probe = "import asyncio; asyncio.new_event_loop().add_signal_handler(2, print)"
    refused = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                             text=True, timeout=60)
    assert ("NotImplementedError" in refused.stderr) == windows_like
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    # Each signal with Python's default before, then ignored, then a handler of the host's.
    assert done.stdout.splitlines() == (["SIGINT stopped True"] * 3
                                        + ["SIGTERM stopped True"] * 3)
