"""`mpc sim --target csim`: a virtual CSIM on a pty pair in a real subprocess, flashed with
`mpc flash` and listing back exactly what was sent; its options and refusals."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]
from click.testing import CliRunner

from mplang import csim
from mplang.cli import (
    EXIT_OK,
    EXIT_RUN_FAILED,
    EXIT_SOURCE_ERRORS,
    EXIT_TRANSPORT,
    EXIT_USAGE,
    main,
)
from mplang.csim.device import Reply, VirtualCsim
from mplang.m8194h.compiler import Options

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"
INDEXER = SAMPLES / "families" / "indexer.mp"
FLOW = SAMPLES / "csim" / "program_flow.csim"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


class SimProcess:
    """`mpc sim --target csim --serial pty ARGS` in a subprocess, and the end it prints."""

    def __init__(self, *args: str | Path) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mplang", "sim", "--target", "csim", "--serial", "pty",
             *(str(a) for a in args)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, cwd=ROOT)
        assert self.proc.stdout is not None
        self.head: list[str] = []
        for line in self.proc.stdout:
            self.head.append(line)
            if "CSIM RS232 on " in line:
                self.port = line.split("CSIM RS232 on ", 1)[1].split()[0]
                return
        self.proc.wait(10)
        raise AssertionError(f"mpc sim did not start: {self.head}")

    def ask(self, text: str) -> list[str]:
        """Send one host line; the echo, data lines and status the device answers."""
        port = serial.Serial(self.port, timeout=2.0)
        answer: list[str] = []
        try:
            port.write(text.encode("ascii") + b"\r")
            while not answer or not (answer[-1] == "OK" or answer[-1].startswith("ERR")):
                raw = port.read_until(b"\r\n")
                assert raw.endswith(b"\r\n"), f"no answer to {text!r} after {answer}"
                answer.append(raw[:-2].decode("ascii"))
        finally:
            port.close()
        return answer

    def stop(self) -> tuple[int, str]:
        self.proc.send_signal(signal.SIGTERM)
        rest, _ = self.proc.communicate(timeout=10)
        return self.proc.returncode, "".join(self.head) + rest


@pytest.fixture
def virtual_csim() -> Iterator[SimProcess]:
    sim = SimProcess("--speed", "50", "-v")
    yield sim
    if sim.proc.poll() is None:
        sim.proc.kill()
        sim.proc.wait(5)


def test_flash_into_mpc_sim_lists_back_what_was_sent(virtual_csim: SimProcess) -> None:
    built = csim.compile_mp([INDEXER], Options(), "csim").programs[0].lines
    code, _, err = run("flash", INDEXER, "--target", "csim", "--serial", virtual_csim.port)
    assert code == EXIT_OK, err
    assert virtual_csim.ask("ULP") == ["ULP", *built, "OK"]
    listed = virtual_csim.ask("PL")
    assert listed[1:-1] == [f"{i:04d}  {text}" for i, text in enumerate(built)]
    assert virtual_csim.ask("G") == ["G", "OK"]
    status, output = virtual_csim.stop()
    assert status == EXIT_OK
    assert output.splitlines()[-1] == "mpc sim: stopped"
    assert "mpc sim: 'DLP' -> OK" in output  # -v shows each host line and its answer


def test_a_preloaded_listing_is_there_from_the_start() -> None:
    sim = SimProcess(FLOW)
    try:
        lines = csim.check_native([FLOW]).programs[0].lines
        assert sim.ask("ULP") == ["ULP", *lines, "OK"]
        assert f"mpc sim: program program_flow ({len(lines)} line(s)) downloaded\n" in sim.head
    finally:
        status, output = sim.stop()
    assert status == EXIT_OK, output


def test_duration_stops_the_service_by_itself() -> None:
    code, out, err = run("sim", "--target", "csim", "--serial", "pty", "--duration", "0.2")
    assert (code, err) == (EXIT_OK, "")
    first, last = out.splitlines()
    assert first.startswith("mpc sim: CSIM RS232 on /dev/") and "(115200 8N1)" in first
    assert last == "mpc sim: stopped"


def test_a_listing_implies_the_csim_target() -> None:
    code, out, _ = run("sim", FLOW, "--serial", "pty", "--duration", "0.1", "--baud", "9600")
    assert code == EXIT_OK and "program program_flow" in out and "(9600 8N1)" in out


def test_a_port_that_cannot_be_opened_exits_6(tmp_path: Path) -> None:
    code, _, err = run("sim", "--target", "csim", "--serial", tmp_path / "ttyNONE",
                       "--duration", "0.1")
    assert code == EXIT_TRANSPORT and "cannot open serial port" in err


def test_a_program_with_errors_exits_1(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csim"
    bad.write_text("JP $NOWHERE\n")
    code, _, err = run("sim", bad, "--serial", "pty", "--duration", "0.1")
    assert code == EXIT_SOURCE_ERRORS and "error[E708]" in err


def test_a_program_the_device_refuses_exits_5(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(VirtualCsim, "preload",
                        lambda _self, _lines: ("TX=0", Reply([], "ERR 3 bad operand")))
    code, _, err = run("sim", FLOW, "--serial", "pty", "--duration", "0.1")
    assert code == EXIT_RUN_FAILED
    assert f"the virtual CSIM refused 'TX=0' of {FLOW}: ERR 3 bad operand" in err


@pytest.mark.parametrize(("args", "words"), [
    (("--target", "fbs-fun140"), ["no FATEK FBs-PLC (fbs-fun140) device to serve",
                                  "mpc run --target fbs-fun140 FILE"]),
    ((SAMPLES / "fatek" / "jog_forward.fbs", "--serial", "pty"), ["no FATEK FBs-PLC device"]),
    (("--target", "csim", "--tcp", "127.0.0.1:0"), ["a CSIM speaks RS232 ASCII, not Modbus"]),
    (("--target", "csim"), ["give --serial PORT, or --serial pty"]),
    (("--target", "csim", "--serial", "pty", "--unit", "2"), ["--unit: M8194H option"]),
    (("--target", "csim", "--serial", "pty", "--memory", "m.json"), ["--memory: M8194H"]),
    ((FLOW, "--target", "et", "--serial", "pty"), ["but the target is et"]),
])
def test_refusals_are_usage_errors(args: tuple[str | Path, ...], words: list[str]) -> None:
    code, _, err = run("sim", *args)
    flat = " ".join(err.split())
    assert code == EXIT_USAGE, err
    for word in words:
        assert word in flat, (word, err)
