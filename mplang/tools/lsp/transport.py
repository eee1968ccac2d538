"""The JSON-RPC framing of `mpc lsp`: bounded, and it survives any input.

pygls reads `Content-Length: N` and then N bytes, trusting both: a huge N is allocated (the
server dies of MemoryError), and a missing, negative, non-numeric or wrong N makes it read the
following messages as part of a broken one, so it never answers again. `serve` replaces
pygls' read loop for stdio and TCP (`MpLanguageServer.start_io`, `start_tcp`):

- A header block is at most MAX_HEADER_BYTES and a body at most MAX_BODY_BYTES; a larger one
  is refused before anything is allocated for it.
- A framing error (no or a bad Content-Length, a header that does not end, a body cut short)
  drops the bad bytes and reads on from the next `Content-Length:`; the skipped bytes are
  read and discarded a chunk at a time.
- A body shorter than its Content-Length is noticed when the next message's header line
  shows up inside it: a JSON text cannot hold one (a raw CR or LF is not allowed in a string,
  and the header name is no JSON outside one), so well-formed traffic never triggers this.
- A body that is not JSON, or not a JSON-RPC message, is dropped; a request whose id can be
  read gets a JSON-RPC error answer (the client would wait for it forever otherwise).

Well-formed traffic is handed to pygls exactly as its own loop does.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import re
import threading
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any, BinaryIO

from pygls.exceptions import JsonRpcException, JsonRpcInternalError, JsonRpcInvalidRequest
from pygls.protocol import JsonRPCProtocol

logger = logging.getLogger("mplang.tools.lsp")

MAX_BODY_BYTES = 64 * 1024 * 1024  # a .mp document is a few KiB; a didOpen of 64 MiB is not one
MAX_HEADER_BYTES = 8 * 1024  # LSP has two short headers (Content-Length, Content-Type)
CHUNK_BYTES = 64 * 1024  # read (and discard) at most this much at a time

_MARK = b"Content-Length:"
# A complete Content-Length header line (bounded: no pathological scans).
_HEADER_LINE = re.compile(rb"Content-Length:[ \t]{0,16}\d{1,20}\r\n")
# The start of one, the rest not yet read (matched up to the end of the buffer).
_HEADER_START = re.compile(rb"Content-Length:[ \t]{0,16}\d{0,20}\r?")
_BLANK = re.compile(rb"[\r\n]*")

Read = Callable[[int], Awaitable[bytes]]  # up to n bytes; b"" at the end of the input
ErrorHandler = Callable[[Exception, type[JsonRpcException]], Any]


@dataclass(frozen=True)
class Dropped:
    """Input that was no message, and why (for the log)."""

    reason: str


class Framer:
    """Cuts a byte stream into message bodies, holding at most one header block or one body
    (plus a chunk) in memory."""

    def __init__(self, read: Read) -> None:
        self._read = read
        self._buffer = bytearray()
        self._eof = False
        self._lost = False  # after a framing error: skip to the next Content-Length

    async def next(self) -> bytes | Dropped | None:
        """The next body, a Dropped for bytes that were none, or None at the end of input."""
        while True:
            if self._lost and not await self._skip_to_header():
                return None
            blank = _BLANK.match(self._buffer)  # blank lines between messages are harmless
            if blank is not None and blank.end():
                del self._buffer[:blank.end()]
            end = self._buffer.find(b"\r\n\r\n")
            if end > MAX_HEADER_BYTES or (end < 0 and len(self._buffer) > MAX_HEADER_BYTES):
                return self._lose(f"a header longer than {MAX_HEADER_BYTES} bytes")
            if end < 0:
                if await self._fill():
                    continue
                if self._buffer:
                    self._buffer.clear()
                    return Dropped("the input ended inside a header")
                return None
            length, problem = _content_length(bytes(self._buffer[:end]))
            if length is None:
                return self._lose(problem)
            del self._buffer[:end + 4]
            return await self._body(length)

    async def _body(self, length: int) -> bytes | Dropped:
        scan = 0
        while True:
            cut, scan, pending = _find_header(self._buffer, scan, length)
            if cut is not None:
                del self._buffer[:cut]
                return Dropped(f"a body ended after {cut} of its {length} bytes (its "
                               "Content-Length was too large): a new message starts there")
            if len(self._buffer) >= length and not pending:
                body = bytes(self._buffer[:length])
                del self._buffer[:length]
                return body
            if not await self._fill():
                missing = length - len(self._buffer)
                self._buffer.clear()
                return Dropped(f"the input ended {max(missing, 0)} bytes short of a body")

    def _lose(self, reason: str) -> Dropped:
        del self._buffer[:1]  # so the search for the next header moves on
        self._lost = True
        return Dropped(reason)

    async def _skip_to_header(self) -> bool:
        """Discard up to the next `Content-Length:`; False at the end of input."""
        while True:
            at = self._buffer.find(_MARK)
            if at >= 0:
                del self._buffer[:at]
                self._lost = False
                return True
            del self._buffer[:max(0, len(self._buffer) - len(_MARK) + 1)]  # keep a cut mark
            if not await self._fill():
                self._buffer.clear()
                return False

    async def _fill(self) -> bool:
        if self._eof:
            return False
        chunk = await self._read(CHUNK_BYTES)
        if not chunk:
            self._eof = True
            return False
        self._buffer += chunk
        return True


def _content_length(header: bytes) -> tuple[int | None, str]:
    """The body length a header block declares, or None and what is wrong with it."""
    length: int | None = None
    for line in header.split(b"\r\n"):
        name, colon, value = line.partition(b":")
        if not colon or not name.strip():
            return None, f"not a header line: {_shown(line)}"
        if name.strip().lower() != b"content-length":
            continue
        text = value.strip()
        if not text.isdigit():
            return None, f"Content-Length {_shown(text)} is not a byte count"
        if len(text) > 12 or int(text) > MAX_BODY_BYTES:
            return None, (f"Content-Length {_shown(text)} is over the limit of "
                          f"{MAX_BODY_BYTES // 2**20} MiB")
        length = int(text)
    if length is None:
        return None, "a message without Content-Length"
    return length, ""


def _shown(data: bytes) -> str:
    return repr(data[:40].decode("utf-8", "replace")) + ("..." if len(data) > 40 else "")


def _find_header(buffer: bytearray, start: int, stop: int) -> tuple[int | None, int, bool]:
    """A header line starting in buffer[start:stop]: (where, or None; where to look next
    time; whether one may be arriving, so that the body is not complete yet)."""
    at = start
    while True:
        at = buffer.find(_MARK, at)
        if at < 0 or at >= stop:
            break
        if _HEADER_LINE.match(buffer, at):
            return at, at, False
        if _HEADER_START.fullmatch(buffer, at):
            return None, at, True
        at += 1
    for size in range(len(_MARK) - 1, 0, -1):  # the end of the buffer cuts a mark
        at = len(buffer) - size
        if start <= at < stop and buffer.endswith(_MARK[:size]):
            return None, at, True
    return None, max(start, len(buffer) - len(_MARK) + 1), False


async def serve(framer: Framer, protocol: JsonRPCProtocol, stop: threading.Event,
                report: Callable[[str], None], error_handler: ErrorHandler) -> None:
    """Hand every message to pygls until the input ends or the server stops; report (log)
    what was dropped."""
    while not stop.is_set():
        item = await framer.next()
        if item is None:
            break
        if isinstance(item, Dropped):
            report(f"dropped input: {item.reason}")
            continue
        dispatch(protocol, item, report, error_handler)


def dispatch(protocol: JsonRPCProtocol, body: bytes, report: Callable[[str], None],
             error_handler: ErrorHandler) -> None:
    """One body: checked to be a JSON-RPC message, then handled as pygls' loop does."""
    try:
        raw = json.loads(body)
    except (ValueError, RecursionError) as exc:  # UnicodeDecodeError is a ValueError
        report(f"dropped a message that is not JSON: {type(exc).__name__}: {exc}")
        return
    request_id = _request_id(raw)
    problem = _shape_problem(raw)
    if problem is not None:
        report(f"dropped a message that is not JSON-RPC: {problem}")
        if request_id is not None:
            _answer_error(protocol, request_id, JsonRpcInvalidRequest(problem))
        return
    try:
        message = json.loads(body, object_hook=protocol.structure_message)
    except Exception as exc:  # params that do not fit the method, say
        cause = f" ({exc.__cause__})" if exc.__cause__ is not None else ""
        report(f"dropped a message that does not fit its method: {type(exc).__name__}: "
               f"{exc}{cause}")
        if request_id is not None:
            error = exc if isinstance(exc, JsonRpcException) else \
                JsonRpcInternalError(f"{type(exc).__name__}: {exc}")
            _answer_error(protocol, request_id, error)
        return
    try:
        protocol.handle_message(message)
    except Exception as exc:
        logger.exception("Unable to handle message")
        error_handler(exc, JsonRpcException)


def _request_id(raw: object) -> int | str | None:
    """The id of a request (not of a response), when it is a valid one."""
    if not isinstance(raw, dict) or "result" in raw or "error" in raw:
        return None
    value = raw.get("id")
    return value if isinstance(value, int | str) and not isinstance(value, bool) else None


_JSON_TYPES = {dict: "an object", list: "an array", str: "a string", int: "a number",
               float: "a number", bool: "a boolean", type(None): "null"}


def _shape_problem(raw: object) -> str | None:
    """What keeps a JSON value from being a JSON-RPC 2.0 message, or None."""
    if not isinstance(raw, dict):
        return f"a message must be an object, not {_JSON_TYPES.get(type(raw), 'that')}"
    if raw.get("jsonrpc") != "2.0":
        return 'no "jsonrpc": "2.0"'
    if "method" in raw:
        if not isinstance(raw["method"], str):
            return '"method" is not a string'
        if "id" in raw and _request_id(raw) is None:
            return '"id" is neither an integer nor a string'
        if not isinstance(raw.get("params"), dict | list | None):
            return '"params" is neither an object nor an array'
        return None
    if "id" in raw and ("result" in raw or "error" in raw):
        return None  # a response to a request of the server
    return "neither a request, a notification nor a response"


def _answer_error(protocol: JsonRPCProtocol, request_id: int | str,
                  error: JsonRpcException) -> None:
    try:
        protocol._send_response(request_id, None, error.to_response_error())
    except Exception:
        logger.exception("cannot answer request %r", request_id)


class PipeReader:
    """Reads a file descriptor in a daemon thread, one chunk when asked.

    A daemon thread, not the event loop's executor: a client that sends `exit` but keeps the
    pipe open does not keep the process alive. `os.read`, not the buffered stdin: the thread
    then holds no lock the interpreter needs when it exits.
    """

    def __init__(self, fd: int) -> None:
        self._fd = fd
        self._asked = threading.Semaphore(0)
        self._request: tuple[asyncio.AbstractEventLoop, asyncio.Future[bytes], int] | None = \
            None
        self._thread: threading.Thread | None = None
        self._ended = False

    async def read(self, size: int) -> bytes:
        if self._ended:
            return b""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[bytes] = loop.create_future()
        self._request = (loop, future, size)
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="mpc-lsp-reader",
                                            daemon=True)
            self._thread.start()
        self._asked.release()
        return await future

    def _run(self) -> None:
        while True:
            self._asked.acquire()
            assert self._request is not None
            loop, future, size = self._request
            try:
                chunk = os.read(self._fd, size)
            except OSError as exc:
                logger.warning("cannot read the input: %s", exc)
                chunk = b""
            self._ended = not chunk
            try:
                loop.call_soon_threadsafe(_settle, future, chunk)
            except RuntimeError:  # the event loop is closed: the server is exiting
                return
            if not chunk:
                return


def _settle(future: asyncio.Future[bytes], chunk: bytes) -> None:
    if not future.done():
        future.set_result(chunk)


def stream_reader(stream: BinaryIO) -> Read:
    """A chunk reader of a binary stream: its file descriptor when it has one."""
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):  # an in-memory stream (tests)
        read_some = getattr(stream, "read1", stream.read)

        async def read(size: int) -> bytes:
            data: bytes = await asyncio.get_running_loop().run_in_executor(None, read_some,
                                                                           size)
            return data

        return read
    return PipeReader(fd).read
