"""The base protocol of both editor protocols (LSP and DAP): `Content-Length: N`, a blank
line, N bytes of JSON. One reader serves `mpc lsp` and `mpc dap`; it is bounded and survives
any input.

Clients (and their bugs) may send a missing, negative, non-numeric, huge or wrong N; a reader
that trusts N either allocates a huge buffer or reads the next messages as part of a broken
one and never answers again. This one:

- holds at most one header block (MAX_HEADER_BYTES) or one body (its `max_body`) plus a
  chunk; a larger one is refused before anything is allocated for it;
- on a framing error (no or a bad Content-Length, a header that does not end, a body cut
  short) drops the bad bytes and reads on from the next `Content-Length:`; skipped bytes are
  discarded a chunk at a time;
- notices a body shorter than its Content-Length when the next message's header line shows
  up inside it: a JSON text cannot hold one (a raw CR or LF is not allowed in a string, and
  the header name is no JSON outside one), so well-formed traffic never triggers this.

`Framer` is the parser alone (bytes in, bodies out), so the same code reads a blocking stream
(`Reader`, `mpc dap`) and an asyncio one (`AsyncReader`, `mpc lsp`). Whether a body is JSON
is the server's question: it decodes it and logs what it drops. This module imports nothing
of pygls, so `mpc dap` works without the `lsp` extra.
"""

from __future__ import annotations

import re
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

MAX_HEADER_BYTES = 8 * 1024  # LSP has two short headers (Content-Length, Content-Type), DAP one
CHUNK_BYTES = 64 * 1024  # read (and discard) at most this much at a time

_MARK = b"Content-Length:"
# A complete Content-Length header line (bounded: no pathological scans).
_HEADER_LINE = re.compile(rb"Content-Length:[ \t]{0,16}\d{1,20}\r\n")
# The start of one, the rest not yet read (matched up to the end of the buffer).
_HEADER_START = re.compile(rb"Content-Length:[ \t]{0,16}\d{0,20}\r?")
_BLANK = re.compile(rb"[\r\n]*")
_TOKEN = re.compile(rb"[!#$%&'*+.^_`|~0-9A-Za-z-]+")  # a header's name (RFC 9110, 5.6.2)


@dataclass(frozen=True)
class Dropped:
    """Input that was no message, and why (for the log)."""

    reason: str


class Framer:
    """Cuts the bytes given to `feed` into message bodies. `next` gives a body, a Dropped,
    or None: more input is needed (feed it), or, once the input ended, there is no more."""

    def __init__(self, max_body: int) -> None:
        self.max_body = max_body
        self.ended = False  # `feed(b"")` was called: the input ended
        self._buffer = bytearray()
        self._lost = False  # after a framing error: skip to the next Content-Length
        self._length: int | None = None  # the body being read
        self._scan = 0  # where to look for a header inside it next

    @property
    def held(self) -> int:
        """The bytes held now (bounded by a header block or a body, plus a chunk)."""
        return len(self._buffer)

    def feed(self, chunk: bytes) -> None:
        """More input; b"" is its end."""
        if chunk:
            self._buffer += chunk
        else:
            self.ended = True

    def next(self) -> bytes | Dropped | None:
        """The next body or Dropped, or None (see the class)."""
        while True:
            if self._length is not None:
                return self._body(self._length)
            if self._lost and not self._skip_to_header():
                return None
            blank = _BLANK.match(self._buffer)  # blank lines between messages are harmless
            if blank is not None and blank.end():
                del self._buffer[:blank.end()]
            end = self._buffer.find(b"\r\n\r\n")
            if end > MAX_HEADER_BYTES or (end < 0 and len(self._buffer) > MAX_HEADER_BYTES):
                return self._lose(f"a header longer than {MAX_HEADER_BYTES} bytes")
            if end < 0:
                if self.ended and self._buffer:
                    self._buffer.clear()
                    return Dropped("the input ended inside a header")
                return None
            length, problem = self._content_length(bytes(self._buffer[:end]))
            if length is None:
                return self._lose(problem)
            del self._buffer[:end + 4]
            self._length, self._scan = length, 0

    def _body(self, length: int) -> bytes | Dropped | None:
        cut, self._scan, pending = _find_header(self._buffer, self._scan, length)
        if cut is not None:
            del self._buffer[:cut]
            self._length = None
            return Dropped(f"a body ended after {cut} of its {length} bytes (its "
                           "Content-Length was too large): a new message starts there")
        if len(self._buffer) >= length and (not pending or self.ended):
            body = bytes(self._buffer[:length])
            del self._buffer[:length]
            self._length = None
            return body
        if not self.ended:
            return None
        missing = length - len(self._buffer)
        self._buffer.clear()
        self._length = None
        return Dropped(f"the input ended {missing} bytes short of a body")

    def _lose(self, reason: str) -> Dropped:
        del self._buffer[:1]  # so the search for the next header moves on
        self._lost = True
        return Dropped(reason)

    def _skip_to_header(self) -> bool:
        """Discard up to the next `Content-Length:`; False if it is not in the input yet."""
        at = self._buffer.find(_MARK)
        if at >= 0:
            del self._buffer[:at]
            self._lost = False
            return True
        del self._buffer[:max(0, len(self._buffer) - len(_MARK) + 1)]  # keep a cut mark
        if self.ended:
            self._buffer.clear()
        return False

    def _content_length(self, header: bytes) -> tuple[int | None, str]:
        """The body length a header block declares, or None and what is wrong with it."""
        length: int | None = None
        for line in header.split(b"\r\n"):
            name, colon, value = line.partition(b":")
            if not colon or not _TOKEN.fullmatch(name.strip()):
                return None, f"not a header line: {_shown(line)}"
            if name.strip().lower() != b"content-length":
                continue
            text = value.strip()
            if not text.isdigit():
                return None, f"Content-Length {_shown(text)} is not a byte count"
            if len(text) > 12 or int(text) > self.max_body:
                limit = (f"{self.max_body // 2**20} MiB" if self.max_body % 2**20 == 0
                         else f"{self.max_body} bytes")
                return None, f"Content-Length {_shown(text)} is over the limit of {limit}"
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


class Reader:
    """Message bodies from a blocking `read(n)` (up to n bytes; b"" at the end)."""

    def __init__(self, read: Callable[[int], bytes], max_body: int) -> None:
        self._read = read
        self._framer = Framer(max_body)

    @property
    def held(self) -> int:
        """The bytes held now (see `Framer.held`)."""
        return self._framer.held

    def next(self) -> bytes | Dropped | None:
        """The next body, a Dropped for bytes that were none, or None at the end of input."""
        framer = self._framer
        while True:
            item = framer.next()
            if item is not None or framer.ended:
                return item
            framer.feed(self._read(CHUNK_BYTES))


class AsyncReader:
    """Message bodies from an awaitable `read(n)` (up to n bytes; b"" at the end)."""

    def __init__(self, read: Callable[[int], Awaitable[bytes]], max_body: int) -> None:
        self._read = read
        self._framer = Framer(max_body)

    @property
    def held(self) -> int:
        """The bytes held now (see `Framer.held`)."""
        return self._framer.held

    async def next(self) -> bytes | Dropped | None:
        """The next body, a Dropped for bytes that were none, or None at the end of input."""
        framer = self._framer
        while True:
            item = framer.next()
            if item is not None or framer.ended:
                return item
            framer.feed(await self._read(CHUNK_BYTES))
