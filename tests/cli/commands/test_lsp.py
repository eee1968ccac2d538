"""`mpc lsp` as a program: options, exit codes, and the TCP transport."""

from __future__ import annotations

import json
import os
import pty
import socket
import subprocess
import sys
import time

from click.testing import CliRunner

from mplang.cli import EXIT_TRANSPORT, EXIT_USAGE, main

SERVER = [sys.executable, "-m", "mplang", "lsp"]


def frame(message: dict[str, object]) -> bytes:
    body = json.dumps(message).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


def read_frame(stream: socket.socket) -> dict[str, object]:
    data = b""
    while b"\r\n\r\n" not in data:
        data += stream.recv(1)
    length = int(data.split(b"Content-Length:")[1].split(b"\r\n")[0])
    body = b""
    while len(body) < length:
        body += stream.recv(length - len(body))
    answer: dict[str, object] = json.loads(body)
    return answer


def test_help_lists_the_options() -> None:
    result = CliRunner().invoke(main, ["lsp", "--help"])
    assert result.exit_code == 0
    assert "--tcp [HOST:]PORT" in result.output and "--target [et|rs]" in result.output


def test_stdio_is_accepted_as_most_editors_pass_it() -> None:
    assert "--stdio" in CliRunner().invoke(main, ["lsp", "--help"]).output
    both = CliRunner().invoke(main, ["lsp", "--stdio", "--tcp", "2087"])
    assert both.exit_code == EXIT_USAGE
    assert "--stdio and --tcp exclude each other" in both.output
    controller, terminal = pty.openpty()
    try:  # --stdio in a terminal: the same hint as without it, not a usage error about it
        done = subprocess.run([*SERVER, "--stdio"], stdin=terminal, capture_output=True,
                              timeout=60)
    finally:
        os.close(controller)
        os.close(terminal)
    assert done.returncode == EXIT_USAGE and b"start it from an editor" in done.stderr


def test_a_bad_port_is_a_usage_error() -> None:
    result = CliRunner().invoke(main, ["lsp", "--tcp", "http"])
    assert result.exit_code == EXIT_USAGE
    assert "write PORT or HOST:PORT" in result.output
    assert CliRunner().invoke(main, ["lsp", "--tcp", "70000"]).exit_code == EXIT_USAGE


def test_a_terminal_on_stdin_gets_a_hint_instead_of_a_silent_wait() -> None:
    controller, terminal = pty.openpty()
    try:
        done = subprocess.run(SERVER, stdin=terminal, capture_output=True, timeout=60)
    finally:
        os.close(controller)
        os.close(terminal)
    assert done.returncode == EXIT_USAGE
    assert b"start it from an editor" in done.stderr


def test_stdio_session_ends_cleanly_on_exit() -> None:
    messages: list[dict[str, object]] = [
        {"jsonrpc": "2.0", "id": 1, "method": "initialize",
         "params": {"processId": None, "rootUri": None, "capabilities": {}}},
        {"jsonrpc": "2.0", "id": 2, "method": "shutdown"},
        {"jsonrpc": "2.0", "method": "exit"},
    ]
    done = subprocess.run(SERVER, input=b"".join(frame(m) for m in messages),
                          capture_output=True, timeout=60)
    assert done.returncode == 0
    assert b'"name": "mpc-lsp"' in done.stdout


def test_a_port_in_use_is_reported_with_the_transport_exit_code() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run([*SERVER, "--tcp", str(port)], capture_output=True, timeout=60,
                              stdin=subprocess.DEVNULL)
    assert done.returncode == EXIT_TRANSPORT
    assert f"cannot listen on 127.0.0.1:{port}".encode() in done.stderr


def test_tcp_serves_one_client() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = subprocess.Popen([*SERVER, "--tcp", f"127.0.0.1:{port}"],
                              stdin=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                connection = socket.create_connection(("127.0.0.1", port), timeout=10)
                break
            except OSError:
                assert time.monotonic() < deadline, "mpc lsp --tcp did not start listening"
                time.sleep(0.05)
        with connection:
            connection.sendall(frame({"jsonrpc": "2.0", "id": 1, "method": "initialize",
                                      "params": {"processId": None, "rootUri": None,
                                                 "capabilities": {}}}))
            answer = read_frame(connection)
            assert answer["id"] == 1 and "capabilities" in answer["result"]  # type: ignore[operator]
            connection.sendall(frame({"jsonrpc": "2.0", "id": 2, "method": "shutdown"}) +
                               frame({"jsonrpc": "2.0", "method": "exit"}))
        assert server.wait(timeout=30) == 0
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()
        assert server.stderr is not None
        server.stderr.close()
