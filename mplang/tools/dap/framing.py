"""The Debug Adapter Protocol's framing over a byte stream: `Content-Length: N`, a blank
line, N bytes of JSON. Bounded, and it survives any input, as `mpc lsp`'s transport does:

- a header line is at most MAX_HEADER_LINE bytes and a body at most MAX_BODY_BYTES; larger
  ones are read and discarded a chunk at a time, never held;
- a line that is no header, or a header block without a valid Content-Length, is dropped
  (`Dropped` says why) and reading goes on with the next line, so the next well-formed
  message is read as usual;
- the end of the input (also inside a message) ends the stream.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from typing import Any, BinaryIO

MAX_HEADER_LINE = 1024  # DAP has one header; a longer line is no header
MAX_BODY_BYTES = 16 * 1024 * 1024  # a request is a few KiB (setBreakpoints of a big file)
CHUNK_BYTES = 64 * 1024


@dataclass(frozen=True)
class Dropped:
    """Input that was no message, and why."""

    reason: str


class Reader:
    """Reads message bodies from `stream` (a binary, blocking file such as stdin)."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream

    def next(self) -> bytes | Dropped | None:
        """The next body, a Dropped for bytes that were none, or None at the end of input."""
        headers: dict[str, str] = {}
        while True:
            line = self._stream.readline(MAX_HEADER_LINE)
            if not line:
                return None
            if line in (b"\r\n", b"\n"):
                if headers:
                    break
                continue  # blank lines between messages are harmless
            if not line.endswith(b"\n"):
                return self._drop_line(line)
            name, colon, value = line.decode("latin-1").partition(":")
            if not colon or not name.strip() or " " in name.strip():
                return Dropped(f"not a header line: {_shown(line)}")
            headers[name.strip().lower()] = value.strip()
        length = headers.get("content-length")
        if length is None:
            return Dropped("a header block without Content-Length")
        if not length.isdigit() or len(length) > 12:
            return Dropped(f"Content-Length {length[:40]!r} is not a byte count")
        size = int(length)
        if size > MAX_BODY_BYTES:
            if not self._discard(size):
                return None
            return Dropped(f"a body of {size} bytes (at most {MAX_BODY_BYTES})")
        body = self._stream.read(size)
        if len(body) < size:
            return None
        return body

    def _drop_line(self, start: bytes) -> Dropped | None:
        """A line longer than any header: read to its end and drop it."""
        while True:
            rest = self._stream.readline(CHUNK_BYTES)
            if not rest:
                return None
            if rest.endswith(b"\n"):
                return Dropped(f"a header line longer than {MAX_HEADER_LINE} bytes: "
                               f"{_shown(start)}")

    def _discard(self, size: int) -> bool:
        while size > 0:
            chunk = self._stream.read(min(size, CHUNK_BYTES))
            if not chunk:
                return False
            size -= len(chunk)
        return True


def _shown(line: bytes) -> str:
    text = line[:40].decode("utf-8", "replace").rstrip("\r\n")
    return repr(text + ("..." if len(line) > 40 else ""))


class Writer:
    """Writes messages to `stream`, one at a time from any thread, numbering them (`seq`)."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self._lock = threading.Lock()
        self._seq = 0

    def send(self, message: dict[str, Any]) -> None:
        with self._lock:
            self._seq += 1
            body = json.dumps({"seq": self._seq, **message}).encode("utf-8")
            self._stream.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
            self._stream.flush()
