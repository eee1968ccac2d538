"""The JSON-RPC transport of `mpc lsp`: bounded, and it survives any input.

pygls reads `Content-Length: N` and then N bytes, trusting both: a huge N is allocated (the
server dies of MemoryError), and a missing, negative, non-numeric or wrong N makes it read the
following messages as part of a broken one, so it never answers again. `serve` replaces
pygls' read loop for stdio and TCP (`MpLanguageServer.start_io`, `start_tcp`):

- Messages are cut by the reader `mpc dap` uses too (`mplang.tools.framing`: bounded, drops
  a bad header or body and reads on from the next `Content-Length:`), with a body limit of
  MAX_BODY_BYTES.
- A body that is not JSON, or not a JSON-RPC message, is dropped; a request whose id can be
  read gets a JSON-RPC error answer (the client would wait for it forever otherwise).

Well-formed traffic is handed to pygls exactly as its own loop does.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import threading
from collections.abc import Awaitable, Callable
from typing import Any, BinaryIO

from pygls.exceptions import JsonRpcException, JsonRpcInternalError, JsonRpcInvalidRequest
from pygls.protocol import JsonRPCProtocol

from mplang.tools.framing import CHUNK_BYTES, MAX_HEADER_BYTES, AsyncReader, Dropped

logger = logging.getLogger("mplang.tools.lsp")

MAX_BODY_BYTES = 64 * 1024 * 1024  # a .mp document is a few KiB; a didOpen of 64 MiB is not one

Read = Callable[[int], Awaitable[bytes]]  # up to n bytes; b"" at the end of the input
ErrorHandler = Callable[[Exception, type[JsonRpcException]], Any]
__all__ = ["CHUNK_BYTES", "MAX_BODY_BYTES", "MAX_HEADER_BYTES", "Dropped", "Framer", "serve",
           "stream_reader"]


class Framer(AsyncReader):
    """The shared bounded reader (`mplang.tools.framing`) with `mpc lsp`'s body limit."""

    def __init__(self, read: Read) -> None:
        super().__init__(read, MAX_BODY_BYTES)


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
