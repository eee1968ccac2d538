"""Both editor protocols' servers against a hostile client: `mpc lsp` and `mpc dap` run as
subprocesses, raw bytes go to their standard input, answers are read from their standard
output. After every kind of bad message (a negative, non-numeric, missing, huge, too large
or too small Content-Length, a body that is not JSON or not UTF-8) the server writes a line
on stderr and answers the next request; it never dies, never hangs.

The reader they share (`mplang.tools.framing`) is also driven in-process, chunk by chunk."""

from __future__ import annotations

import io
import json
import os
import queue
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.tools.dap.framing import Writer
from mplang.tools.framing import CHUNK_BYTES, MAX_HEADER_BYTES, Dropped, Framer, Reader

WAIT_S = 30.0  # a bound on an answer that never comes: a hung server fails the test
BAD_MESSAGES = {  # what is sent, and what the line on stderr says
    "negative": (b"Content-Length: -5\r\n\r\n{}", "'-5' is not a byte count"),
    "non-numeric": (b"Content-Length: twelve\r\n\r\n{}", "'twelve' is not a byte count"),
    "missing": (b"Content-Type: application/json\r\n\r\n{}", "without Content-Length"),
    "huge": (b"Content-Length: 99999999999999999\r\n\r\n" + b"x" * 300, "over the limit"),
    "too large (the body is short)": (b'Content-Length: 5000\r\n\r\n{"a": 1}',
                                      "its Content-Length was too large"),
    "too small (the body goes on)": (b'Content-Length: 3\r\n\r\n{"seq": 7, "type": "req"}',
                                     "not JSON"),
    "not JSON": (b"Content-Length: 9\r\n\r\n{not json", "not JSON"),
    "not UTF-8": (b'Content-Length: 10\r\n\r\n{"a":"\xff\xfe"}', "UnicodeDecodeError"),
    "no blank line": (b"Content-Length: 2\r\n{}", "not a header line"),
}


def frame(message: dict[str, Any]) -> bytes:
    body = json.dumps(message).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


class RawClient:
    """A server as a subprocess; what it writes is collected by threads."""

    def __init__(self, command: str, cwd: Path) -> None:
        self.process = subprocess.Popen([sys.executable, "-m", "mplang", command], cwd=cwd,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE)
        self.messages: queue.Queue[dict[str, Any] | None] = queue.Queue()
        self.stderr = bytearray()
        self.stderr_grew = threading.Condition()
        assert self.process.stdout is not None and self.process.stderr is not None
        threading.Thread(target=self._collect, args=(self.process.stdout.fileno(),),
                         daemon=True).start()
        threading.Thread(target=self._drain, args=(self.process.stderr.fileno(),),
                         daemon=True).start()

    def _collect(self, fd: int) -> None:
        framer = Framer(1 << 24)
        while True:
            item = framer.next()
            if isinstance(item, Dropped):
                raise AssertionError(f"the server wrote a bad frame: {item.reason}")
            if item is not None:
                self.messages.put(json.loads(item))
            elif framer.ended:
                self.messages.put(None)
                return
            else:
                framer.feed(os.read(fd, 65536))

    def _drain(self, fd: int) -> None:
        while chunk := os.read(fd, 65536):
            with self.stderr_grew:
                self.stderr += chunk
                self.stderr_grew.notify_all()

    def logged(self, text: str, start: int) -> int:
        """Wait (bounded) until stderr holds `text` at or after `start`; where it ends."""
        wanted = text.encode()
        with self.stderr_grew:
            if not self.stderr_grew.wait_for(lambda: self.stderr.find(wanted, start) >= 0,
                                             WAIT_S):
                raise AssertionError(f"{text!r} not on stderr: "
                                     f"{bytes(self.stderr[start:][-2000:])!r}")
            return self.stderr.find(wanted, start) + len(wanted)

    def send(self, data: bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(data)
        self.process.stdin.flush()

    def answer(self, key: str, value: int) -> dict[str, Any]:
        """The next message whose `key` is `value` (others are passed over)."""
        while True:
            try:
                message = self.messages.get(timeout=WAIT_S)
            except queue.Empty:
                raise AssertionError(f"no answer within {WAIT_S} s; stderr: "
                                     f"{bytes(self.stderr[-2000:])!r}") from None
            assert message is not None, f"the server ended; stderr: {bytes(self.stderr)!r}"
            if message.get(key) == value and "method" not in message:
                return message

    def close(self) -> int:
        assert self.process.stdin is not None
        self.process.stdin.close()
        try:
            return self.process.wait(WAIT_S)
        finally:
            assert self.process.stdout is not None and self.process.stderr is not None
            self.process.stdout.close()
            self.process.stderr.close()


class Lsp:
    """`mpc lsp`, initialized; a request is a workspace/symbol query."""

    command = "lsp"

    def __init__(self, client: RawClient, cwd: Path) -> None:
        self.client = client
        client.send(frame({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {
            "processId": None, "rootUri": cwd.as_uri(), "capabilities": {}}}))
        assert "capabilities" in client.answer("id", 1)["result"]
        client.send(frame({"jsonrpc": "2.0", "method": "initialized", "params": {}}))

    def ask(self, number: int) -> None:
        self.client.send(frame({"jsonrpc": "2.0", "id": number, "method": "workspace/symbol",
                                "params": {"query": "x"}}))
        assert "result" in self.client.answer("id", number)

    def end(self) -> None:
        self.client.send(frame({"jsonrpc": "2.0", "id": 2, "method": "shutdown"}))
        self.client.answer("id", 2)
        self.client.send(frame({"jsonrpc": "2.0", "method": "exit"}))


class Dap:
    """`mpc dap`, initialized; a request is `threads`."""

    command = "dap"

    def __init__(self, client: RawClient, cwd: Path) -> None:
        self.client = client
        client.send(frame({"seq": 1, "type": "request", "command": "initialize",
                           "arguments": {"adapterID": "mpc"}}))
        assert client.answer("request_seq", 1)["success"]

    def ask(self, number: int) -> None:
        self.client.send(frame({"seq": number, "type": "request", "command": "threads"}))
        answer = self.client.answer("request_seq", number)
        assert answer["success"] and answer["body"] == {"threads": []}

    def end(self) -> None:
        self.client.send(frame({"seq": 2, "type": "request", "command": "disconnect"}))
        self.client.answer("request_seq", 2)


@pytest.fixture(params=[Lsp, Dap], ids=["lsp", "dap"])
def server(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Lsp | Dap]:
    kind: type[Lsp] | type[Dap] = request.param
    client = RawClient(kind.command, tmp_path)
    try:
        yield kind(client, tmp_path)
    finally:
        if client.process.poll() is None:
            client.process.kill()
        client.close()


def test_a_bad_message_is_dropped_with_a_log_line_and_the_next_request_answered(
        server: Lsp | Dap) -> None:
    client = server.client
    seen = 0  # the lines are in order: each bad message's after the one before
    for number, (kind, (data, said)) in enumerate(BAD_MESSAGES.items(), start=100):
        client.send(data)
        server.ask(number)
        seen = client.logged(said, seen)
        assert client.process.poll() is None, kind
    server.end()
    assert client.close() == 0


def test_garbage_in_one_write_with_requests_between(server: Lsp | Dap) -> None:
    """Every bad message back to back, a good request after each, all in one write: each
    request is answered (the reader resynchronises on the next header every time)."""
    data = b""
    for number, (bad, _said) in enumerate(BAD_MESSAGES.values(), start=200):
        data += bad
        data += b"" if number % 2 else b"\r\n"  # with and without a blank line between
        data += frame(_request(server, number))
    server.client.send(data)
    for number in range(200, 200 + len(BAD_MESSAGES)):
        server.client.answer("id" if isinstance(server, Lsp) else "request_seq", number)
    assert server.client.process.poll() is None


def _request(server: Lsp | Dap, number: int) -> dict[str, Any]:
    if isinstance(server, Lsp):
        return {"jsonrpc": "2.0", "id": number, "method": "workspace/symbol",
                "params": {"query": "x"}}
    return {"seq": number, "type": "request", "command": "threads"}


# ------------------------------------------------------------------ the reader in-process
FAST = settings(max_examples=150, deadline=None, database=None, derandomize=True)


def read_all(data: bytes, chunk: int = 7, max_body: int = 1000) -> list[bytes | Dropped]:
    """Every body and drop of `data`, fed `chunk` bytes at a time."""
    pieces = iter([data[i:i + chunk] for i in range(0, len(data), chunk)])
    reader = Reader(lambda _size: next(pieces, b""), max_body)
    found: list[bytes | Dropped] = []
    for _ in range(len(data) + 2):
        item = reader.next()
        if item is None:
            return found
        found.append(item)
    raise AssertionError("the reader did not reach the end of its input")


@FAST
@given(st.binary(max_size=2000), st.integers(1, 64))
def test_reader_survives_any_bytes_then_reads_a_good_message(garbage: bytes,
                                                             chunk: int) -> None:
    good = frame({"seq": 1, "type": "request", "command": "threads"})
    found = read_all(garbage + b"\r\n" + good, chunk)
    assert all(isinstance(item, (bytes, Dropped)) for item in found)
    if b"Content-Length" not in garbage:
        assert found[-1] == good.split(b"\r\n\r\n", 1)[1]


@pytest.mark.parametrize("kind", BAD_MESSAGES)
def test_reader_drops_each_bad_message_and_reads_the_next(kind: str) -> None:
    good = frame({"seq": 1, "type": "request", "command": "threads"})
    found = read_all(BAD_MESSAGES[kind][0] + good)
    assert found[-1] == good.split(b"\r\n\r\n", 1)[1], found
    bodies = [item for item in found[:-1] if isinstance(item, bytes)]
    for body in bodies:  # what was let through as a body is no message
        with pytest.raises(ValueError):
            json.loads(body)["command"]


@FAST
@given(st.lists(st.text(st.characters(blacklist_characters=":\r\n",
                                      blacklist_categories=("Cs",)), max_size=60),
                max_size=5))
def test_reader_finds_a_request_after_garbage_lines(garbage: list[str]) -> None:
    request = {"seq": 1, "type": "request", "command": "threads"}
    data = b"".join(line.encode() + b"\r\n" for line in garbage) + b"\r\n" + frame(request)
    bodies = [m for m in read_all(data) if isinstance(m, bytes)]
    assert bodies == [json.dumps(request).encode()]


def test_dap_writer_frames_and_numbers_messages() -> None:
    out = io.BytesIO()
    writer = Writer(out)
    writer.send({"type": "event", "event": "initialized"})
    writer.send({"type": "event", "event": "terminated"})
    bodies = read_all(out.getvalue())
    assert [json.loads(b)["seq"] for b in bodies if isinstance(b, bytes)] == [1, 2]
    # the header as the DAP specification spells it (clients may match it exactly)
    first = json.dumps({"seq": 1, "type": "event", "event": "initialized"}).encode()
    assert out.getvalue().startswith(b"Content-Length: %d\r\n\r\n%s" % (len(first), first))


def test_reader_holds_no_more_than_its_bounds() -> None:
    """A header past MAX_HEADER_BYTES and a body past the limit are dropped unread."""
    huge_line = b"X" * (MAX_HEADER_BYTES * 3)
    good = frame({"seq": 2})
    found = read_all(huge_line + b"\r\n\r\n" + b"Content-Length: 1001\r\n\r\n" + b"y" * 1001
                     + good, chunk=4096)
    reasons = [item.reason for item in found if isinstance(item, Dropped)]
    assert any("header longer than" in r for r in reasons)
    assert any("over the limit of 1000 bytes" in r for r in reasons)
    assert found[-1] == good.split(b"\r\n\r\n", 1)[1]


def test_reader_at_the_end_of_input_inside_a_message() -> None:
    assert [getattr(m, "reason", m) for m in read_all(b"Content-Length: 10\r\n\r\n{}")] == [
        "the input ended 8 bytes short of a body"]
    assert [getattr(m, "reason", m) for m in read_all(b"Content-Length: 10\r\n")] == [
        "the input ended inside a header"]


def test_mpc_dap_needs_no_pygls() -> None:
    """The adapter and its reader import nothing of the `lsp` extra."""
    code = ("import sys, mplang.tools.dap, mplang.cli.commands.dap; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pygls', 'lsprotocol')))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=WAIT_S, check=True)
    assert result.stdout.strip() == "[]"


def reasons(data: bytes, chunk: int = 7, max_body: int = 1000) -> list[bytes | str]:
    """`read_all`, with each Dropped as its reason."""
    return [item.reason if isinstance(item, Dropped) else item
            for item in read_all(data, chunk, max_body)]


def test_reader_says_what_it_dropped_word_for_word() -> None:
    """Each reason names the bad value, cut to 40 characters with '...' after (its bytes
    read as UTF-8, a bad byte shown as U+FFFD)."""
    good = frame({"seq": 1})
    body = good.split(b"\r\n\r\n", 1)[1]
    forty = b"a" * 40
    cases: list[tuple[bytes, str]] = [
        (b"Content-Length: -5\r\n\r\n{}", "Content-Length '-5' is not a byte count"),
        (b"Content-Length: \xff2\r\n\r\n{}", "Content-Length '\ufffd2' is not a byte count"),
        (b"Content-Length: 1001\r\n\r\n", "Content-Length '1001' is over the limit of 1000 bytes"),
        (b"Content-Type: x\r\n\r\n{}", "a message without Content-Length"),
        (forty + b"\r\n\r\n", f"not a header line: '{'a' * 40}'"),
        (forty + b"b\r\n\r\n", f"not a header line: '{'a' * 40}'..."),
        (b"Content-Length: 400\r\n\r\n{\"cut\"", "a body ended after 6 of its 400 bytes (its "
         "Content-Length was too large): a new message starts there"),
    ]
    for bad, reason in cases:
        assert reasons(bad + good) == [reason, body], bad
    for mib in (1, 16):
        assert reasons(b"Content-Length: 99999999\r\n\r\n" + good, max_body=mib * 2**20) == [
            f"Content-Length '99999999' is over the limit of {mib} MiB", body]


def test_reader_resynchronises_on_a_header_one_byte_into_a_bad_block() -> None:
    """The bad bytes are dropped up to the next `Content-Length:`, even one that starts
    at the second byte of the block that was refused."""
    assert reasons(b"XContent-Length: 2\r\n\r\n{}") == ["a message without Content-Length", b"{}"]


def test_reader_asks_for_a_chunk_at_a_time() -> None:
    """Bounded reads: the reader never asks its stream for more than CHUNK_BYTES."""
    asked: list[int] = []
    pieces = iter([frame({"seq": 1}), b""])

    def read(size: int) -> bytes:
        asked.append(size)
        return next(pieces)

    reader = Reader(read, 1000)
    assert reader.next() == b'{"seq": 1}' and reader.next() is None
    assert asked == [CHUNK_BYTES, CHUNK_BYTES]


def test_after_a_resynchronisation_each_bad_message_is_reported_again() -> None:
    """Skipping ends at the header found: a later bad message gets its own reason."""
    good = frame({"seq": 1})
    body = good.split(b"\r\n\r\n", 1)[1]
    assert reasons(b"bad\r\n\r\n" + good + b"Content-Type: x\r\n\r\n{}" + good) == [
        "not a header line: 'bad'", body, "a message without Content-Length", body]


def test_skipped_bytes_are_dropped_silently_keeping_only_a_cut_mark() -> None:
    """After a framing error, input up to the next `Content-Length:` is discarded without
    another reason, even where it looks like a header block; what is held meanwhile is at
    most the start of a mark cut by the end of the input (its length less one byte)."""
    framer = Framer(1000)
    framer.feed(b"bad\r\n\r\n")
    assert framer.next() == Dropped("not a header line: 'bad'")
    assert framer.next() is None
    framer.feed(b"junk\r\n\r\n" + b"x" * 100)
    assert framer.next() is None
    assert framer.held == len(b"Content-Length:") - 1
    framer.feed(frame({"seq": 1}))
    assert framer.next() == b'{"seq": 1}'


def test_a_complete_message_is_given_before_the_input_ends() -> None:
    """A server answers a request without waiting for the next one: a body is returned as
    soon as its last byte is in, exactly its Content-Length (here also the limit)."""
    framer = Framer(10)
    framer.feed(b"Content-Length: 10\r\n\r\n" + b'{"a": 123}')
    assert framer.next() == b'{"a": 123}'
    assert framer.next() is None and not framer.ended
    # nor for the rest of the next message's header, whose first bytes came with it
    framer.feed(b"Content-Length: 2\r\n\r\n{}" + b"Content-Le")
    assert framer.next() == b"{}"


def test_header_fields_as_http_defines_them() -> None:
    """The base protocol's header is HTTP's: a field name ends at its first colon, names
    ignore case, fields come in any order, space around a value is no part of it, and a
    count may have leading zeros (RFC 9110, 5.1, 5.5 and 8.6)."""
    cases = [b"Content-Type: application/vscode-jsonrpc; charset=utf-8\r\nContent-Length: 2",
             b"X-Note: a:b\r\nContent-Length: 2",
             b"content-length: 2",
             b"CONTENT-LENGTH:\t 2 ",
             b"Content-Length: 000000000002"]
    for header in cases:
        assert reasons(header + b"\r\n\r\n{}") == [b"{}"], header


def test_the_bounds_are_inclusive() -> None:
    """A header block of exactly MAX_HEADER_BYTES is read, one byte more is refused; a
    body of exactly the limit is read, one byte more is refused."""
    def block(size: int) -> bytes:
        head = b"Content-Length: 2\r\nX-Pad: "
        return head + b"p" * (size - len(head))

    framer = Framer(1000)
    framer.feed(block(MAX_HEADER_BYTES))  # all of it held, the blank line not in yet
    assert framer.next() is None
    framer.feed(b"\r\n\r\n{}")
    assert framer.next() == b"{}"
    assert reasons(block(MAX_HEADER_BYTES + 1) + b"\r\n\r\n{}", chunk=4096) == [
        f"a header longer than {MAX_HEADER_BYTES} bytes"]
    assert reasons(b"Content-Length: 1000\r\n\r\n" + b"x" * 1000) == [b"x" * 1000]


def test_a_body_cut_short_by_the_next_header_at_any_point() -> None:
    """The next message's header found inside a body cuts it, wherever it starts (at the
    body's first byte too), and however the reads split that header: while the end of the
    input may be the start of one, the body waits for more."""
    good = frame({"seq": 1})
    body = good.split(b"\r\n\r\n", 1)[1]
    cut = ("a body ended after {} of its {} bytes (its Content-Length was too large): "
           "a new message starts there")
    assert reasons(b"Content-Length: 50\r\n\r\n" + good) == [cut.format(0, 50), body]
    framer = Framer(1000)  # the first header inside it cuts it, not a later one
    framer.feed(b'Content-Length: 200\r\n\r\n{"cut"' + good + good)
    assert [framer.next(), framer.next(), framer.next()] == [Dropped(cut.format(6, 200)),
                                                             body, body]
    for split in range(1, len(b"Content-Length: 12\r\n")):
        framer = Framer(1000)
        framer.feed(b'Content-Length: 8\r\n\r\n{"cut"' + good[:split])
        assert framer.next() is None, split  # 6 + split bytes may be a body of 8: wait
        framer.feed(good[split:])
        assert [framer.next(), framer.next()] == [Dropped(cut.format(6, 8)), body], split
    for declared in range(7, 26):  # the header fed a byte at a time: a body of any length
        framer = Framer(1000)
        framer.feed(b"Content-Length: %d\r\n\r\n{\"cut\"" % declared)
        found = []
        for byte in good:
            framer.feed(bytes([byte]))
            while (item := framer.next()) is not None:
                found.append(item)
        assert found == [Dropped(cut.format(6, declared)), body], declared
