"""A serial line without hardware: two pseudo-terminals joined back to back.

The device opens one end by name, the client (pymodbus, mbpoll, a PLC program under test)
the other. A thread copies bytes between the two pty masters. Ptys ignore the baud rate;
by default nothing models wire timing, and `seconds_per_chunk` (bench/flash.py) may hold each
chunk for its time on a real wire.
"""

from __future__ import annotations

import os
import pty
import select
import threading
import time
import tty
from collections.abc import Callable


class PtyLink:
    """Two linked ptys; `device_end` and `client_end` are the paths to open.
    `seconds_per_chunk(data)`, if given, is how long each chunk is held before it is passed
    on (one chunk at a time, as on a half-duplex line)."""

    def __init__(self, seconds_per_chunk: Callable[[bytes], float] | None = None) -> None:
        self._pace = seconds_per_chunk
        self._masters: list[int] = []
        self._slaves: list[int] = []
        for _ in range(2):
            master, slave = pty.openpty()
            tty.setraw(slave)  # no echo, no newline translation: RTU is binary
            self._masters.append(master)
            self._slaves.append(slave)
        self.device_end = os.ttyname(self._slaves[0])
        self.client_end = os.ttyname(self._slaves[1])
        self._stop_read, self._stop_write = os.pipe()
        self._thread = threading.Thread(target=self._relay, name="pty-link", daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        a, b = self._masters
        peer = {a: b, b: a}
        while True:
            ready, _, _ = select.select([a, b, self._stop_read], [], [])
            if self._stop_read in ready:
                return
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue  # nobody has the other end open yet
                if data:
                    if self._pace is not None:
                        time.sleep(self._pace(data))
                    os.write(peer[fd], data)

    def close(self) -> None:
        os.write(self._stop_write, b"x")
        self._thread.join(timeout=2)
        for fd in (*self._masters, *self._slaves, self._stop_read, self._stop_write):
            os.close(fd)

    def __enter__(self) -> PtyLink:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
