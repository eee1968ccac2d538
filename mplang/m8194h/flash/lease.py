"""One downloader at a time: the lease `mpc flash` keeps in the device's machine data while it
writes (docs/flash.md, "One downloader at a time").

The M8194H has no lock of its own: two clients that download at once interleave their frames
in its one download state machine, and one of them may empty a slot that held a good program.
So before it writes anything a flash takes a lease in machine data that every mpc reads
first: who holds it (host, process id, a random token), when it was taken and last renewed,
and for how long it holds without renewal. Machine data are non-volatile (manual 3.19), so a
lease survives the power cycle of a device and expires by its time, never by a restart.

The range is the profile's (`[flash_lease] range` in stdlib/m8194h/device.toml, below the
build manifest's default range), the lifetime `[flash_lease] seconds`. Layout, one 32-bit MD
word after the other from the first MD of the range:

    0  magic "MPCL" (0x4D50434C); 0: no lease
    1  CRC-32 of words 2.. (each big-endian), so a lease written by someone else shows
    2  taken at, Unix seconds (UTC)
    3  renewed at, Unix seconds (UTC): the lease holds until renewed + lifetime
    4  lifetime, seconds
    5  token: a random 32-bit number of the holder's run
    6  process id of the holder
    7.. host name: a length byte and UTF-8, zero-padded, big-endian in each word

Taking it is Fischer's protocol over one device: read (free, expired, or ours), write the
whole lease in one request, wait `settle` seconds, read it back: a client that read "free"
at the same time wrote within that wait, and only the last writer finds its own token. The
wait must outlast another client's gap between its read and its write (one round trip):
mpc waits one answer timeout.
"""

from __future__ import annotations

import asyncio
import os
import secrets
import socket
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime

from mplang.ir.catalogue import Profile
from mplang.m8194h.flash.manifest import (
    MAX_PER_WRITE,
    MD_HOLDING_BASE,
    MdRange,
    counted,
    from_registers,
    parse_range,
    to_registers,
)
from mplang.m8194h.modbus import DeviceLink

MAGIC = 0x4D50434C  # "MPCL"
HEADER_WORDS = 7
POLL_S = 0.5  # how often a waiting flash reads the lease again


@dataclass(frozen=True)
class Holder:
    """Who holds a lease, as its words say."""

    host: str
    pid: int
    token: int
    taken: int  # Unix seconds
    renewed: int
    seconds: int

    def expired(self, now: float) -> bool:
        return now > self.renewed + self.seconds

    def describe(self, now: float) -> str:
        """"mpc flash on HOST (pid N, lease 1a2b3c4d) since 2026-...Z, expiring in 25 s"."""
        left = self.renewed + self.seconds - now
        expiry = f"expiring in {left:.0f} s" if left >= 0 else f"expired {-left:.0f} s ago"
        return (f"mpc flash on {self.host} (pid {self.pid}, lease {self.token:08x}) since "
                f"{_stamp(self.taken)}, {expiry}")


def _stamp(seconds: int) -> str:
    return datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%d %H:%M:%SZ")


class LeaseHeld(Exception):
    """Another client holds the lease (and did not let go within the wait): the message
    names it and when it started."""


@dataclass(frozen=True)
class LeaseSettings:
    md: MdRange
    seconds: int

    @staticmethod
    def of(profile: Profile) -> LeaseSettings:
        raw = profile.raw["flash_lease"]
        md = parse_range(str(raw["range"]))
        if md.count > MAX_PER_WRITE:  # written in one request, or two clients could mix
            raise ValueError(f"device profile [flash_lease] range {md}: at most "
                             f"{MAX_PER_WRITE} MD (one Modbus write)")
        return LeaseSettings(md, int(raw["seconds"]))

    def overlaps(self, other: MdRange) -> bool:
        return self.md.first <= other.last and other.first <= self.md.last


def encode(holder: Holder, words: int) -> list[int]:
    """The MD words of `holder`, `words` long (zero-padded), checksum included."""
    body = counted(holder.host, 4 * (words - HEADER_WORDS) - 1)
    body += bytes(4 * (words - HEADER_WORDS) - len(body))
    out = [MAGIC, 0, holder.taken & 0xFFFFFFFF, holder.renewed & 0xFFFFFFFF,
           holder.seconds & 0xFFFFFFFF, holder.token & 0xFFFFFFFF, holder.pid & 0xFFFFFFFF,
           *(int.from_bytes(body[i:i + 4], "big") for i in range(0, len(body), 4))]
    out[1] = _crc(out)
    return out


def _crc(words: Sequence[int]) -> int:
    return zlib.crc32(b"".join(w.to_bytes(4, "big") for w in words[2:])) & 0xFFFFFFFF


def decode(words: Sequence[int]) -> Holder | None:
    """The holder the words name; None for no lease (no magic, or a checksum that fails:
    not a lease mpc wrote)."""
    if len(words) <= HEADER_WORDS or words[0] != MAGIC or words[1] != _crc(words):
        return None
    body = b"".join(w.to_bytes(4, "big") for w in words[HEADER_WORDS:])
    host = body[1:1 + body[0]].decode("utf-8", errors="replace")
    return Holder(host, words[6], words[5], words[2], words[3], words[4])


def me(seconds: int, now: float) -> Holder:
    """A new lease for this process: host, pid and a random token."""
    stamp = int(now)
    return Holder(socket.gethostname() or "unknown host", os.getpid(),
                  secrets.randbits(32), stamp, stamp, seconds)


class Lease:
    """This flash's lease on one device: `take` before anything is written, `check` before
    each program (renewing it), `release` at the end. `clock` gives Unix seconds."""

    def __init__(self, link: DeviceLink, settings: LeaseSettings, word_order: int,
                 wait: float = 0.0, progress: Callable[[str], None] | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        self.link = link
        self.md = settings.md
        self.seconds = settings.seconds
        self.word_order = word_order
        self.wait = wait
        self.progress = progress or (lambda _text: None)
        self.clock = clock
        self.mine: Holder | None = None

    async def read(self) -> Holder | None:
        """The lease the device holds, in either word order: a flash that sets holding
        register 14 changes how its own lease reads, never whether it is there."""
        registers = await self.link.read_holding(MD_HOLDING_BASE + 2 * self.md.first,
                                                 2 * self.md.count)
        for order in (self.word_order, 1 - self.word_order):
            held = decode(from_registers(registers, order))
            if held is not None:
                return held
        return None

    async def _write(self, holder: Holder | None) -> None:
        words = [0] * self.md.count if holder is None else encode(holder, self.md.count)
        await self.link.write_holding(MD_HOLDING_BASE + 2 * self.md.first,
                                      to_registers(words, self.word_order))

    async def take(self) -> None:
        """Hold the lease, waiting up to `wait` seconds for another client's to end or
        expire; LeaseHeld names that client otherwise."""
        deadline = time.monotonic() + self.wait
        said = False
        while True:
            held = await self.read()
            now = self.clock()
            if held is not None and not held.expired(now) and \
                    (self.mine is None or held.token != self.mine.token):
                if time.monotonic() >= deadline:
                    waited = f" (waited {self.wait:g} s)" if self.wait else ""
                    raise LeaseHeld(f"the device is leased by {held.describe(now)}{waited}: "
                                    "nothing was written; flash again when it is done, or "
                                    "wait for it with --wait-lease SECONDS")
                if not said:
                    self.progress(f"waiting up to {self.wait:g} s for the device's lease, "
                                  f"held by {held.describe(now)}")
                    said = True
                await asyncio.sleep(min(POLL_S, max(0.0, deadline - time.monotonic())))
                continue
            if held is not None and held.expired(now) and (
                    self.mine is None or held.token != self.mine.token):
                self.progress(f"note: taking over an expired lease of {held.describe(now)}")
            self.mine = me(self.seconds, now)
            await self._write(self.mine)
            await asyncio.sleep(self.link.endpoint.timeout)  # others' read-to-write gap
            if await self.read() == self.mine:
                return

    async def check(self, before: str) -> None:
        """Before `before` (a program's label, or "the end"): the lease must still be this
        flash's; renewed when a third of its lifetime has passed. LeaseHeld otherwise."""
        assert self.mine is not None
        held = await self.read()
        now = self.clock()
        if held is None or held.token != self.mine.token:
            who = f"by {held.describe(now)}" if held is not None else \
                "(its machine data were cleared or overwritten by another client)"
            self.mine = None
            raise LeaseHeld(f"this flash's lease on the device was taken {who}; stopped "
                            f"before {before}")
        if now - held.renewed >= self.seconds / 3:
            self.mine = replace(self.mine, renewed=int(now))
            await self._write(self.mine)

    async def release(self) -> None:
        """Give the lease back if it is still this flash's."""
        if self.mine is None:
            return
        mine, self.mine = self.mine, None
        held = await self.read()
        if held is not None and held.token == mine.token:
            await self._write(None)

    async def other(self) -> str | None:
        """Another client's lease, described, if the device holds one (for a message about
        a client that downloads at the same time)."""
        held = await self.read()
        if held is None or (self.mine is not None and held.token == self.mine.token):
            return None
        return held.describe(self.clock())
