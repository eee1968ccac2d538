"""A serial line without hardware: two pseudo-terminals joined back to back.

The device opens one end by name, the client (pymodbus, mbpoll, a PLC program under test)
the other. A thread copies bytes between the two pty masters. Ptys ignore the baud rate;
by default nothing models wire timing. With a `Wire` (bench/flash.py) each chunk is passed
on when its last byte would have arrived over a real RTU line: the line is busy for every
byte (start, data, parity and stop bits) and keeps the 3.5-character silence the standard
requires before a frame, and no more. The wire keeps its own clock, so the time the two
ends take to answer is hidden in that silence when it is shorter, and a late wake-up of
the relay delays one chunk without shifting the ones after it.

Pseudo-terminals are POSIX: on Windows `PtyLink()` raises `PtyUnavailable`, whose message
names the stand-in there, a com0com-style pair of linked virtual COM ports.
"""

from __future__ import annotations

import math
import os
import select
import sys
import threading
import time
from dataclasses import dataclass, field

NO_PTY = ("a linked pseudo-terminal pair (--serial pty) needs a POSIX system; on Windows, "
          "install a pair of linked virtual COM ports (com0com or the like, e.g. COM5<->COM6) "
          "and give one end with --serial COM5")


class PtyUnavailable(OSError):
    """This platform has no pseudo-terminals (Windows)."""


@dataclass
class Wire:
    """The timing of one half-duplex RTU line: `bits_per_char` bits a byte at `baudrate`
    (8N1: 10), and `gap_chars` characters of silence before every frame (3.5)."""

    baudrate: int
    bits_per_char: int = 10
    gap_chars: float = 3.5
    free_at: float = field(default=-math.inf, init=False)  # when the last byte is through
    last_sender: int = field(default=-1, init=False)

    @property
    def char_time(self) -> float:
        return self.bits_per_char / self.baudrate

    def deliver_at(self, sender: int, size: int, now: float) -> float:
        """When a chunk of `size` bytes that `sender` wrote at `now` is through: at once
        after what is on the line if it continues the frame being sent (same sender, before
        the silence that would end it), else after that silence; never before `now`."""
        gap = self.gap_chars * self.char_time
        continues = sender == self.last_sender and now < self.free_at + gap
        start = max(now, self.free_at if continues else self.free_at + gap)
        self.free_at = start + size * self.char_time
        self.last_sender = sender
        return self.free_at


class PtyLink:
    """Two linked ptys; `device_end` and `client_end` are the paths to open. With a
    `wire`, every chunk is held until it would be through a real line (see `Wire`)."""

    # Declared here, not only in __init__: on Windows (mypy --platform win32) __init__ stops
    # at its first line, and the rest of the class still needs their types.
    device_end: str
    client_end: str
    _wire: Wire | None
    _masters: list[int]
    _slaves: list[int]
    _stop_read: int
    _stop_write: int
    _thread: threading.Thread

    def __init__(self, wire: Wire | None = None) -> None:
        if sys.platform == "win32":
            raise PtyUnavailable(NO_PTY)
        try:
            import pty
            import tty
        except ImportError:  # a Python built without them
            raise PtyUnavailable(NO_PTY) from None
        self._wire = wire
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
                    if self._wire is not None:
                        due = self._wire.deliver_at(fd, len(data), time.monotonic())
                        time.sleep(max(0.0, due - time.monotonic()))
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
