"""Network and serial failures say why (issue 15 item 6): connection refused, no such host,
no answer, no such serial device, permission denied, port already in use; for every command
that opens a connection (`mpc flash`, `mpc status`, `mpc sim`, of the M8194H and the CSIM),
each in one line naming the address, with exit 7 (no device) for a device that cannot be
reached and 6 (transport) for what `mpc sim` cannot open. The failures are real ones: a
closed loopback port, an `.invalid` name (RFC 2606: it never resolves), /dev/does-not-exist,
a port bound first, a socket that listens and never answers."""

from __future__ import annotations

import errno
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

from mplang.cli.common import EXIT_NO_DEVICE, EXIT_TRANSPORT
from mplang.family.linkfail import connect_reason, listen_reason, serial_reason

JOB = "MP 3 first\n    VAR1 = 1\nEND MP\n"


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=120, cwd=cwd)


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture
def work(tmp_path: Path) -> Path:
    (tmp_path / "job.mp").write_text(JOB)
    (tmp_path / "p.csim").write_text("MA 100\n")
    return tmp_path


@pytest.fixture
def bound() -> Iterator[int]:
    """A loopback port something listens on and never answers (nor accepts: the kernel
    completes the connection all the same)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(8)
        yield int(sock.getsockname()[1])


def one_line(text: str) -> str:
    lines = [line for line in text.splitlines() if "error" in line]
    assert len(lines) == 1, text
    return lines[0]


def test_connection_refused_for_status_and_flash(work: Path) -> None:
    port = closed_port()
    reason = f"cannot connect to 127.0.0.1:{port} (Modbus TCP): connection refused"
    status = mpc(work, "status", "--tcp", f"127.0.0.1:{port}")
    assert status.returncode == EXIT_NO_DEVICE and reason in one_line(status.stderr)
    flash = mpc(work, "flash", "job.mp", "--tcp", f"127.0.0.1:{port}", "--record", "r.json")
    assert flash.returncode == EXIT_NO_DEVICE and reason in one_line(flash.stderr)


def test_no_such_host_for_status_flash_and_sim(work: Path) -> None:
    status = mpc(work, "status", "--tcp", "no-such-controller.invalid:502")
    assert status.returncode == EXIT_NO_DEVICE
    assert "cannot connect to no-such-controller.invalid:502 (Modbus TCP): no such host" \
        in one_line(status.stderr)
    flash = mpc(work, "flash", "job.mp", "--tcp", "no-such-controller.invalid",
                "--record", "r.json")
    assert flash.returncode == EXIT_NO_DEVICE and "no such host" in flash.stderr
    sim = mpc(work, "sim", "--tcp", "no-such-controller.invalid:1502", "--duration", "1")
    assert sim.returncode == EXIT_TRANSPORT
    assert "cannot listen on no-such-controller.invalid:1502: no such host" in sim.stderr


def test_no_answer_is_a_timeout(work: Path, bound: int) -> None:
    status = mpc(work, "status", "--tcp", f"127.0.0.1:{bound}", "--timeout", "0.2",
                 "--retries", "0")
    assert status.returncode == EXIT_NO_DEVICE
    assert f"127.0.0.1:{bound} unit 1: no answer within 0.2 s" in one_line(status.stderr)


def test_no_such_serial_device_for_every_command(work: Path) -> None:
    missing = "/dev/does-not-exist"
    modbus = f"cannot open serial port {missing} (Modbus RTU, 115200 8N1): no such serial " \
        "device"
    status = mpc(work, "status", "--serial", missing)
    assert status.returncode == EXIT_NO_DEVICE and modbus in one_line(status.stderr)
    flash = mpc(work, "flash", "job.mp", "--serial", missing, "--record", "r.json")
    assert flash.returncode == EXIT_NO_DEVICE and modbus in one_line(flash.stderr)
    csim = f"cannot open serial port {missing} (CSIM RS232, 115200 8N1): no such serial device"
    csim_status = mpc(work, "status", "p.csim", "--serial", missing)
    assert csim_status.returncode == EXIT_NO_DEVICE and csim in one_line(csim_status.stderr)
    csim_flash = mpc(work, "flash", "p.csim", "--serial", missing)
    assert csim_flash.returncode == EXIT_TRANSPORT and csim in one_line(csim_flash.stderr)
    for family in ((), ("--target", "csim")):
        sim = mpc(work, "sim", *family, "--serial", missing, "--duration", "1")
        assert sim.returncode == EXIT_TRANSPORT
        assert f"cannot open serial port {missing}: no such serial device" in sim.stderr


def test_port_already_in_use_for_sim(work: Path, bound: int) -> None:
    sim = mpc(work, "sim", "--tcp", f"127.0.0.1:{bound}", "--duration", "1")
    assert sim.returncode == EXIT_TRANSPORT
    assert f"cannot listen on 127.0.0.1:{bound}: port already in use" in one_line(sim.stderr)


def test_the_reasons_of_the_operating_systems_errors() -> None:
    """The mapping itself, on the exceptions the libraries raise: real ones where this
    machine can make them (a refused connect, a failed lookup, pyserial's failed open),
    constructed ones for what a root test runner cannot meet (permission denied)."""
    with socket.socket() as sock, pytest.raises(OSError) as refused:
        sock.connect(("127.0.0.1", closed_port()))
    assert connect_reason(refused.value).startswith("connection refused")
    with pytest.raises(socket.gaierror) as lookup:
        socket.getaddrinfo("no-such-controller.invalid", 502)
    assert connect_reason(lookup.value).startswith("no such host")
    assert listen_reason(lookup.value).startswith("no such host")
    with pytest.raises(serial.SerialException) as opened:
        serial.Serial("/dev/does-not-exist")
    assert serial_reason(opened.value) == "no such serial device"
    assert connect_reason(None) == connect_reason(TimeoutError()) == "no answer (timed out)"
    denied = OSError(errno.EACCES, "Permission denied")
    assert serial_reason(denied).startswith("permission denied")
    assert listen_reason(denied).startswith("permission denied (ports below 1024")
    assert serial_reason(OSError(errno.EBUSY, "busy")) == "in use by another program"
    assert listen_reason(OSError(errno.EADDRINUSE, "in use")).startswith(
        "port already in use")
    assert connect_reason(OSError(errno.EHOSTUNREACH, "x")) == "no route to host"
