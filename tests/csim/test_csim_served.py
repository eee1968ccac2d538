"""The served CSIM (`mpc sim --target csim --serial pty`, a real subprocess) talked to over its
pty with the CSIM protocol, as a host would: every sample program downloaded with DLP and
run with G ends where `mpc run` ends it (the jog of CS 22-27 too); a host's TAPZ pause of a
running program is ended by the host's TAREDO or TAUPZ (CS 206-208); modules T4..T7 move,
and PN50=1 from the host leaves only the host linked (CS 238-245)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

from mplang import csim

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted((ROOT / "samples" / "csim").glob("*.csim"))
POLLS = 2000
"""How many times a test asks ?ST before it gives up on a program ending (no deadline:
each poll waits 10 ms of wall time, whatever the machine's load)."""


class ServedCsim:
    """`mpc sim --target csim --serial pty --speed 50`, and a host on the other pty end."""

    def __init__(self) -> None:
        self.unsolicited: list[str] = []  # lines sent by a running program, not answers
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mplang", "sim", "--target", "csim", "--serial", "pty",
             "--speed", "50"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            cwd=ROOT)
        assert self.proc.stdout is not None
        head = []
        for line in self.proc.stdout:
            head.append(line)
            if "CSIM RS232 on " in line:
                path = line.split("CSIM RS232 on ", 1)[1].split()[0]
                self.port = serial.Serial(path, timeout=5.0)
                return
        self.proc.wait(10)
        raise AssertionError(f"mpc sim did not start: {head}")

    def ask(self, text: str) -> list[str]:
        """Send one line (ended by CR); the data lines and the status line of the answer."""
        self.port.write(text.encode("ascii") + b"\r")
        answer: list[str] = []
        while not answer or not (answer[-1] == "OK" or answer[-1].startswith("ERR")):
            raw = self.port.read_until(b"\r\n")
            assert raw.endswith(b"\r\n"), f"no answer to {text!r} after {answer}"
            line = raw[:-2].decode("ascii")
            if not answer and line != text:  # what a running program sends (OUT) meanwhile
                self.unsolicited.append(line)
                continue
            answer.append(line)
        return answer[1:]

    def status(self, text: str) -> str:
        return self.ask(text)[-1]

    def value(self, query: str) -> float:
        data, status = self.ask(query)
        assert status == "OK", (query, status)
        return float(data)

    def download(self, lines: list[str]) -> None:
        for text in ["DLP", *lines, ""]:
            assert self.status(text) == "OK", text

    def wait_until(self, state: str) -> None:
        for _ in range(POLLS):
            data = self.ask("?ST")
            if data[0] == state:
                return
            time.sleep(0.01)
        raise AssertionError(f"?ST never said {state}: {data}")

    def close(self) -> None:
        self.port.close()
        self.proc.send_signal(signal.SIGTERM)
        self.proc.communicate(timeout=10)


@pytest.fixture(scope="module")
def served() -> Iterator[ServedCsim]:
    device = ServedCsim()
    yield device
    device.close()


@pytest.mark.parametrize("path", SAMPLES, ids=[p.name for p in SAMPLES])
def test_cs_22_27_served_and_mpc_run_end_at_the_same_place(served: ServedCsim, path: Path) -> None:
    """CS 22-27 (jog) and every other sample: the device runs the program against the wall
    clock, `mpc run` in simulated time; both end at the same positions."""
    build = csim.check_native([path])
    offline = csim.run_build(build, None, 600.0)
    assert offline.error is None
    served.download(build.programs[0].lines)
    assert served.status("RESET H") == "OK"  # a fresh machine: every module at 0
    assert served.status("G") == "OK"
    served.wait_until("IDLE")
    ends = {name: served.value(f"?{'' if module == 0 else f'T{module}'}PE")
            for module, name in enumerate("XYZU")}
    expected = {name: axis["lp"] for name, axis in offline.to_json()["axes"].items()
                if name in ends}
    assert ends == pytest.approx(expected, abs=1e-6)


def test_cs_206_208_a_host_pause_of_a_running_program_is_resumed_by_the_host(
        served: ServedCsim) -> None:
    served.download(["TX=0", "TY=1", "2MA 20000,0", "DN", "XMR 5"])
    assert served.status("RESET H") == "OK"
    assert served.status("G") == "OK"
    assert served.status("TAPZ") == "OK"  # 外部: accepted while the program runs
    served.wait_until("PAUSE")
    assert served.status("XMA 3").startswith("ERR 4")  # still busy
    paused_at = served.value("?PE")
    assert served.status("TAREDO") == "OK"
    served.wait_until("IDLE")
    assert served.value("?PE") == 20005 and paused_at < 20000  # the path went on, then XMR

    assert served.status("RESET H") == "OK"
    assert served.status("G") == "OK"
    assert served.status("TAPZ") == "OK"
    served.wait_until("PAUSE")
    assert served.status("TAUPZ") == "OK"  # drops the paused 2MA; the program goes on
    served.wait_until("IDLE")
    dropped = served.value("?PE")
    assert dropped < 20005  # the 2MA was dropped where it stood; XMR 5 ran from there


def test_cs_238_245_pn50_modules_t4_to_t7(served: ServedCsim, tmp_path: Path) -> None:
    """The virtual CSIM is a SLIM system with T0..T7 linked (PN50 = 0FFH): T4..T7 move under
    `mpc run` and on the device; PN50=1 from the host leaves only T0 linked."""
    source = tmp_path / "far.csim"
    source.write_text("T4MA 100\nT7MR -50\nT4DN\nT7DN\n")
    run = csim.run_build(csim.check_native([source]), None, 60.0)
    assert run.error is None and run.finished
    assert run.to_json()["axes"]["T4"]["lp"] == 100 and run.to_json()["axes"]["T7"]["lp"] == -50
    assert served.status("RESET H") == "OK"
    assert served.status("T5MA 7") == "OK"
    assert served.status("PN50=1") == "OK"
    assert served.status("T5MA 9").startswith("ERR 8 run error: module T5 is not linked")
