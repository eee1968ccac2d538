"""`mpc lsp` against a hostile client: broken framing, messages that are no JSON-RPC, and
requests on devices, FIFOs and huge files. The server must answer the next good request
every time, stay alive, and read nothing it should not.

The end-to-end test writes raw bytes to the real server's stdin; every read of its stdout is
bounded by a timeout, so a server that hangs fails the test instead of hanging it.
"""

from __future__ import annotations

import asyncio
import json
import os
import queue
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from mplang.ir.unit import Options
from mplang.tools.lsp.analysis import analyse
from mplang.tools.lsp.transport import MAX_BODY_BYTES, Dropped, Framer
from mplang.tools.lsp.workspace import MAX_FILE_BYTES, BuildContext, RefusedFile, read_text

SERVER = [sys.executable, "-m", "mplang", "lsp"]
ANSWER_SECONDS = 30.0  # generous: a loaded 2-core machine starts the server in ~8 s
MAIN = "CONST SPEED = 5000\nMP 1\n    SET_V X, SPEED\nEND MP\n"


def frame(message: object) -> bytes:
    body = message if isinstance(message, bytes) else json.dumps(message).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


class Session:
    """The server as a subprocess; its messages are collected by a thread."""

    def __init__(self, cwd: Path) -> None:
        self.process = subprocess.Popen(SERVER, cwd=cwd, stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.messages: queue.Queue[dict[str, object]] = queue.Queue()
        self.seen: list[dict[str, object]] = []
        self.stderr = bytearray()
        assert self.process.stdout is not None and self.process.stderr is not None
        threading.Thread(target=self._collect, args=(self.process.stdout.fileno(),),
                         daemon=True).start()
        threading.Thread(target=self._drain, args=(self.process.stderr.fileno(),),
                         daemon=True).start()
        self.next_id = 100

    def _collect(self, fd: int) -> None:
        data = b""
        while True:
            chunk = os.read(fd, 65536)
            if not chunk:
                return
            data += chunk
            while b"\r\n\r\n" in data:
                header, rest = data.split(b"\r\n\r\n", 1)
                length = int(header.split(b"Content-Length:")[1].split(b"\r\n")[0])
                if len(rest) < length:
                    break
                self.messages.put(json.loads(rest[:length]))
                data = rest[length:]

    def _drain(self, fd: int) -> None:
        while chunk := os.read(fd, 65536):
            self.stderr += chunk

    def send(self, data: bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(data)
        self.process.stdin.flush()

    def request(self, method: str, params: object = None) -> int:
        self.next_id += 1
        self.send(frame({"jsonrpc": "2.0", "id": self.next_id, "method": method,
                         "params": params}))
        return self.next_id

    def wait_for(self, wanted: str, key: object) -> dict[str, object]:
        """The answer to request `key` (wanted="id") or the next notification `key`."""
        deadline = time.monotonic() + ANSWER_SECONDS
        while True:
            remaining = deadline - time.monotonic()
            try:
                message = self.messages.get(timeout=max(remaining, 0.001))
            except queue.Empty:
                raise AssertionError(f"no {wanted} {key!r} within {ANSWER_SECONDS} s; "
                                     f"stderr: {bytes(self.stderr[-2000:])!r}") from None
            self.seen.append(message)
            if message.get(wanted) == key and (wanted != "id" or "method" not in message):
                return message

    def answer(self, request_id: int) -> dict[str, object]:
        return self.wait_for("id", request_id)

    def hover(self, uri: str, line: int = 2, character: int = 6) -> dict[str, object]:
        return self.answer(self.request("textDocument/hover", {
            "textDocument": {"uri": uri}, "position": {"line": line, "character": character}}))

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(timeout=10)
        for stream in (self.process.stdin, self.process.stdout, self.process.stderr):
            if stream is not None:
                stream.close()


@pytest.fixture
def session(tmp_path: Path) -> Iterator[Session]:
    running = Session(tmp_path)
    try:
        yield running
    finally:
        running.close()


def test_the_server_survives_a_hostile_client(session: Session, tmp_path: Path) -> None:
    started = session.request("initialize", {"processId": None, "rootUri": tmp_path.as_uri(),
                                             "capabilities": {}})
    assert "capabilities" in session.answer(started)["result"]  # type: ignore[operator]
    session.send(frame({"jsonrpc": "2.0", "method": "initialized", "params": {}}))
    main = (tmp_path / "main.mp").as_uri()
    session.send(frame({"jsonrpc": "2.0", "method": "textDocument/didOpen", "params": {
        "textDocument": {"uri": main, "languageId": "mplang", "version": 1, "text": MAIN}}}))

    def still_serving() -> None:
        hover = session.hover(main)["result"]
        assert isinstance(hover, dict) and "SET_V" in json.dumps(hover)
        assert session.process.poll() is None

    still_serving()
    junk = b'{"jsonrpc": "2.0", "id": 9000, "method": "shutdown"}'  # must never be obeyed
    for hostile in (
            b"Content-Length: 99999999999\r\n\r\n" + junk,
            b"Content-Length: %d\r\n\r\n" % (MAX_BODY_BYTES + 1) + junk,
            b"Content-Length: -5\r\n\r\n" + junk,
            b"Content-Length: abc\r\n\r\n" + junk,
            b"Content-Type: application/vscode-jsonrpc; charset=utf-8\r\n\r\n" + junk,
            b"Content-Length: 500\r\n\r\n" + junk[:20],  # short: the next message follows
            b"Content-Length: 5\r\n\r\n" + junk,  # long: the rest is junk before a header
            b"X" * 20000,  # a header that never ends
            frame(b"{not json"),
            frame(b"\xff\xfe\x00"),
            frame(b"[" * 100000),
            frame(b"[1, 2, 3]"),
            frame(b'{"hello": "world"}'),
            frame({"jsonrpc": "2.0", "method": 42}),
            frame({"jsonrpc": "2.0", "method": "textDocument/didOpen", "params": 7}),
            frame({"jsonrpc": "2.0", "method": "$/unknownNotification"}),
    ):
        session.send(hostile)
        still_serving()
    assert all(m.get("id") != 9000 for m in session.seen)
    dropped = [m for m in session.seen if m.get("method") == "window/logMessage"
               and "dropped" in json.dumps(m)]
    assert len(dropped) >= 10

    # Requests whose id can be read get an error answer, never silence.
    session.send(frame({"id": 77, "method": "textDocument/hover"}))
    assert session.answer(77)["error"]["code"] == -32600  # type: ignore[index]
    unknown = session.request("mplang/noSuchMethod", {})
    assert session.answer(unknown)["error"]["code"] == -32601  # type: ignore[index]
    unfit = session.request("textDocument/hover", {"textDocument": 5})
    assert session.answer(unfit)["error"]["code"] == -32602  # type: ignore[index]
    still_serving()

    # Documents the client did not open: only small regular files are read.
    fifo = tmp_path / "pipe.mp"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.mp"
    with huge.open("wb") as sparse:
        sparse.truncate(50 * 1024 * 1024)
    for uri in ("file:///dev/zero", fifo.as_uri(), huge.as_uri(), "file:///dev/stdin"):
        for method in ("textDocument/hover", "textDocument/definition",
                       "textDocument/completion", "textDocument/codeLens"):
            params: dict[str, object] = {"textDocument": {"uri": uri}}
            if method != "textDocument/codeLens":
                params["position"] = {"line": 0, "character": 0}
            assert session.answer(session.request(method, params))["result"] is None
        still_serving()
    refused = [json.dumps(m) for m in session.seen if m.get("method") == "window/logMessage"]
    assert any("not a regular file" in m for m in refused)
    assert any("larger than 1 MiB" in m for m in refused)

    # An INCLUDE of a FIFO or a device is reported, not read.
    including = (tmp_path / "including.mp").as_uri()
    session.send(frame({"jsonrpc": "2.0", "method": "textDocument/didOpen", "params": {
        "textDocument": {"uri": including, "languageId": "mplang", "version": 1,
                         "text": 'INCLUDE "pipe.mp"\nINCLUDE "huge.mp"\n' + MAIN}}}))
    published = session.wait_for("method", "textDocument/publishDiagnostics")
    while published["params"]["uri"] != including:  # type: ignore[index]
        published = session.wait_for("method", "textDocument/publishDiagnostics")
    diagnostics = published["params"]["diagnostics"]  # type: ignore[index]
    diagnostics.sort(key=lambda d: d["range"]["start"]["line"])
    messages = [d["message"] for d in diagnostics]
    assert len(messages) == 2, messages
    assert "not a regular file" in messages[0] and "larger than 1 MiB" in messages[1]
    still_serving()

    assert session.answer(session.request("shutdown"))["result"] is None
    session.send(frame({"jsonrpc": "2.0", "method": "exit"}))
    assert session.process.wait(timeout=10) == 0


def test_exit_ends_the_process_while_the_client_keeps_the_pipe_open(
        session: Session, tmp_path: Path) -> None:
    started = session.request("initialize", {"processId": None, "rootUri": None,
                                             "capabilities": {}})
    session.answer(started)
    session.answer(session.request("shutdown"))
    session.send(frame({"jsonrpc": "2.0", "method": "exit"}))
    assert session.process.wait(timeout=10) == 0  # stdin is still open


def test_tcp_resynchronises_too() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = subprocess.Popen([*SERVER, "--tcp", f"127.0.0.1:{port}"],
                              stdin=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                connection = socket.create_connection(("127.0.0.1", port), timeout=5)
                break
            except OSError:
                assert time.monotonic() < deadline, "mpc lsp --tcp did not start listening"
                time.sleep(0.05)
        with connection:
            connection.sendall(b"Content-Length: 99999999999\r\n\r\n{}" +
                               b"Content-Length: -3\r\n\r\n{}" + frame(
                                   {"jsonrpc": "2.0", "id": 1, "method": "initialize",
                                    "params": {"processId": None, "rootUri": None,
                                               "capabilities": {}}}))
            received = b""
            while b'"id": 1' not in received:
                chunk = connection.recv(65536)  # times out (fails) after 5 s
                assert chunk, "the server closed the connection"
                received += chunk
            connection.sendall(frame({"jsonrpc": "2.0", "id": 2, "method": "shutdown"}) +
                               frame({"jsonrpc": "2.0", "method": "exit"}))
        assert server.wait(timeout=10) == 0
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()


# ---------------------------------------------------------------------- the framing alone
def cut(stream: bytes, size: int) -> list[bytes | str]:
    """What the framer makes of `stream` read `size` bytes at a time: bodies, and the reasons
    of what it dropped."""
    chunks = [stream[i:i + size] for i in range(0, len(stream), size)]

    async def read(_wanted: int) -> bytes:
        return chunks.pop(0) if chunks else b""

    async def run() -> list[bytes | str]:
        framer = Framer(read)
        found: list[bytes | str] = []
        while (item := await framer.next()) is not None:
            found.append(item.reason if isinstance(item, Dropped) else item)
        return found

    return asyncio.run(run())


GOOD = b'{"jsonrpc": "2.0", "id": 1, "method": "shutdown"}'


@pytest.mark.parametrize("size", [1, 7, 65536])
def test_well_formed_traffic_is_cut_into_its_messages(size: int) -> None:
    stream = b"\r\n" + frame(GOOD) + b"Content-Length: 2\r\nContent-Type: x\r\n\r\n{}" + \
        frame(b'{"text": "Content-Length: 12 inside a string"}')
    assert cut(stream, size) == [GOOD, b"{}",
                                 b'{"text": "Content-Length: 12 inside a string"}']


@pytest.mark.parametrize("size", [1, 5, 65536])
@pytest.mark.parametrize(("bad", "reason"), [
    (b"Content-Length: 99999999999\r\n\r\n{}", "over the limit of 64 MiB"),
    (b"Content-Length: -1\r\n\r\n{}", "not a byte count"),
    (b"Content-Length: twelve\r\n\r\n{}", "not a byte count"),
    (b"Content-Length:\r\n\r\n{}", "not a byte count"),
    (b"Content-Type: text/plain\r\n\r\n{}", "without Content-Length"),
    (b"garbage\r\n\r\n", "not a header line"),
    (b"Content-Length: 400\r\n\r\n{\"cut\"", "ended after 6 of its 400 bytes"),
    (b"Content-Length: 60\r\n\r\n{\"cut\"", "ended after 6 of its 60 bytes"),
    (b"Z" * 9000, "header longer than"),
])
def test_a_framing_error_drops_one_message_and_the_next_one_arrives(
        bad: bytes, reason: str, size: int) -> None:
    found = cut(frame(GOOD) + bad + frame(GOOD), size)
    assert found[0] == GOOD and found[-1] == GOOD
    assert any(isinstance(item, str) and reason in item for item in found[1:-1]), found


def test_a_huge_declared_body_is_never_allocated() -> None:
    body = 12 * 1024 * 1024  # no header in it: all of it is read and discarded
    pieces = iter([frame(GOOD), b"Content-Length: 99999999999\r\n\r\n",
                   *([b"x" * 65536] * (body // 65536)), frame(GOOD)])
    held: list[int] = []

    async def read(wanted: int) -> bytes:
        assert wanted <= 65536
        held.append(framer.held)
        return next(pieces, b"")

    async def run() -> list[bytes | str]:
        found: list[bytes | str] = []
        while (item := await framer.next()) is not None:
            found.append(item.reason if isinstance(item, Dropped) else item)
        return found

    framer = Framer(read)
    found = asyncio.run(run())
    assert found[0] == GOOD and found[-1] == GOOD and "over the limit" in str(found[1])
    assert max(held) < 65536  # what is held between reads: never the declared body


def test_the_end_of_input_inside_a_message_ends_cleanly() -> None:
    assert cut(b"Content-Length: 10\r\n\r\n{}", 4) == ["the input ended 8 bytes short of a body"]
    assert cut(b"Content-Len", 4) == ["the input ended inside a header"]


# ---------------------------------------------------------------------- reading files
def test_only_small_regular_files_are_read(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.mp"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.mp"
    with huge.open("wb") as sparse:
        sparse.truncate(MAX_FILE_BYTES + 1)
    for path, reason in ((Path("/dev/zero"), "not a regular file"),
                         (fifo, "not a regular file"), (huge, "larger than 1 MiB")):
        with pytest.raises(RefusedFile, match=reason):
            read_text(path)
    crlf = tmp_path / "crlf.mp"
    crlf.write_bytes(b"MP 1\r\nEND MP\rX\n")
    assert read_text(crlf) == crlf.read_text(encoding="utf-8") == "MP 1\nEND MP\nX\n"
    with pytest.raises(IsADirectoryError):
        read_text(tmp_path)
    with pytest.raises(FileNotFoundError):
        read_text(tmp_path / "missing.mp")


def test_an_include_of_a_special_file_is_an_error_not_a_read(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.mp")
    (tmp_path / "dev.mp").symlink_to("/dev/zero")
    (tmp_path / "ok.mp").write_text("CONST A = 1\n")
    text = 'INCLUDE "pipe.mp"\nINCLUDE "dev.mp"\nINCLUDE "ok.mp"\nINCLUDE "gone.mp"\n'
    # The symlink leads out of the project: allowed, so that it is the device that is refused.
    context = BuildContext((tmp_path / "main.mp",), Options(allow_outside_includes=True))
    analysis = analyse(tmp_path / "main.mp", text, context)
    found = sorted((d.range.start.line, d.code, d.message) for d in analysis.diagnostics)
    assert [(line, code) for line, code, _ in found] == [(0, "E102"), (1, "E102"),
                                                         (3, "E102")]
    assert "pipe.mp: not a regular file" in found[0][2]
    assert "dev.mp: not a regular file" in found[1][2]
    assert "No such file" in found[2][2]
    assert "A" in analysis.consts
