"""The Debug Adapter Protocol's messages over a byte stream: read with the bounded,
resynchronising reader both editor protocols share (`mplang.tools.framing`), written here
numbered (`seq`)."""

from __future__ import annotations

import json
import threading
from typing import Any, BinaryIO

from mplang.tools.framing import Dropped, Reader

MAX_BODY_BYTES = 16 * 1024 * 1024  # a request is a few KiB (setBreakpoints of a big file)

__all__ = ["MAX_BODY_BYTES", "Dropped", "Writer", "reader"]


def reader(stream: BinaryIO) -> Reader:
    """The messages of a blocking binary stream (stdin), read as they arrive."""
    read = getattr(stream, "read1", stream.read)
    return Reader(read, MAX_BODY_BYTES)


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
