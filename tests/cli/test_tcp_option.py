"""One `--tcp` convention for every command (issue 19 item 7): `mpc sim --tcp 1503` once read
1503 as a host name while `mpc lsp --tcp 1503` read it as a port. Now a bare number is a port
everywhere (on 127.0.0.1), HOST alone takes the command's usual port, and each command is
checked through its real transport on loopback."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from simproc import start_sim

from mplang.cli import EXIT_OK, EXIT_USAGE, main
from mplang.tools.project import load_project, parse_address

ROOT = Path(__file__).resolve().parents[2]
MPC = [sys.executable, "-m", "mplang"]


@pytest.mark.parametrize(("text", "default", "expected"), [
    ("1503", 502, ("127.0.0.1", 1503)),  # a bare number is a port, never a host name
    ("1503", None, ("127.0.0.1", 1503)),
    (":1503", 502, ("127.0.0.1", 1503)),
    ("plc.local", 502, ("plc.local", 502)),
    ("plc.local", 1502, ("plc.local", 1502)),
    ("10.0.0.2:1503", 502, ("10.0.0.2", 1503)),
    ("[::1]:1503", 502, ("::1", 1503)),
    ("[::1]", 502, ("::1", 502)),
    ("fe80::1", 502, ("fe80::1", 502)),
])
def test_one_address_convention(text: str, default: int | None,
                                expected: tuple[str, int]) -> None:
    assert parse_address(text, default) == expected


@pytest.mark.parametrize(("text", "default"), [
    ("plc.local", None), ("h:http", 502), ("h:", 502), ("70000", 502), ("h:0", 502),
    ("[::1", 502), ("[::1]x", 502), ("[]:5", 502), ("h:+5", 502), ("h: 5", 502),
    ("h:\u0665", 502),  # an Arabic-Indic digit: isdigit, but no port number
])
def test_what_is_not_an_address_is_named(text: str, default: int | None) -> None:
    with pytest.raises(ValueError, match=r"PORT|port"):
        parse_address(text, default)
    assert parse_address("0", 502, any_port=True) == ("127.0.0.1", 0)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def connect(port: int, process: subprocess.Popen[str] | subprocess.Popen[bytes]
            ) -> socket.socket:
    """Connect to 127.0.0.1:port once the server listens (it was started just before)."""
    deadline = time.monotonic() + 30
    while True:
        try:
            return socket.create_connection(("127.0.0.1", port), timeout=10)
        except OSError:
            assert process.poll() is None, "the server stopped"
            assert time.monotonic() < deadline, "the server did not start listening"
            time.sleep(0.05)


def test_mpc_sim_tcp_port_serves_on_loopback() -> None:
    port = free_port()
    server = subprocess.Popen([*MPC, "sim", "--tcp", str(port), "--duration", "30"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert server.stdout is not None
        first = server.stdout.readline()
        assert f"Modbus TCP on 127.0.0.1:{port}" in first, first
        with connect(port, server) as client:  # Modbus TCP: read input register 81 (FC4)
            client.sendall(bytes([0, 1, 0, 0, 0, 6, 1, 4, 0, 81, 0, 1]))
            answer = client.recv(64)
        assert answer[:2] == b"\x00\x01" and answer[7] == 4
    finally:
        server.kill()
        server.wait()
        if server.stdout is not None:
            server.stdout.close()
    usage = CliRunner().invoke(main, ["sim", "--tcp", "localhost:http"])
    assert usage.exit_code == EXIT_USAGE and "PORT (on 127.0.0.1)" in usage.output


def test_mpc_lsp_tcp_port_serves_on_loopback() -> None:
    port = free_port()
    server = subprocess.Popen([*MPC, "lsp", "--tcp", str(port)], stdin=subprocess.DEVNULL,
                              stderr=subprocess.PIPE)
    try:
        with connect(port, server) as client:
            body = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "initialize",
                               "params": {"processId": None, "rootUri": None,
                                          "capabilities": {}}}).encode()
            client.sendall(b"Content-Length: %d\r\n\r\n" % len(body) + body)
            assert b"Content-Length" in client.recv(65536)
    finally:
        server.kill()
        server.wait()
        if server.stderr is not None:
            server.stderr.close()
    usage = CliRunner().invoke(main, ["lsp", "--tcp", "localhost"])  # no port to guess
    assert usage.exit_code == EXIT_USAGE and "write PORT or HOST:PORT" in usage.output


def test_mpc_flash_tcp_port_reaches_a_local_sim(tmp_path: Path) -> None:
    proc, port = start_sim("--duration", "30")
    try:
        done = subprocess.run([*MPC, "flash", str(ROOT / "samples" / "tour.mp"), "--tcp",
                               str(port), "--record", str(tmp_path / "record.json")],
                              capture_output=True, text=True, timeout=120, cwd=tmp_path)
        assert done.returncode == EXIT_OK, done.stderr
        assert "verified" in done.stderr
    finally:
        proc.kill()
        proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


def test_a_project_device_given_as_a_bare_port_is_on_loopback(tmp_path: Path) -> None:
    (tmp_path / "a.mp").write_text("MP 1\n    VAR1 = 1\nEND MP\n")
    path = tmp_path / "mpc.toml"
    path.write_text('[project]\nsources = "a.mp"\n[targets.bench]\ntcp = "1503"\n')
    bench = load_project(path).targets["bench"]
    assert (bench.host, bench.port) == ("127.0.0.1", 1503)
