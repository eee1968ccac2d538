"""Mixed Modbus load against a served virtual controller, for the soak test and bench/:
pollers reading positions and status the way HMIs do, and clients sending random frames (valid
and invalid function codes, wrong lengths, garbage, half frames, abrupt closes), all on
loopback. Every loop is bounded by a deadline and stops by itself."""

from __future__ import annotations

import asyncio
import contextlib
import random
import struct
import time
from dataclasses import dataclass, field

# The function codes a poller uses, and the ones random frames draw from: the device's own
# (1-6, 15, 16) and codes it does not serve.
POLLED = ((4, 0, 100), (4, 100, 20), (3, 0, 10), (3, 300, 40), (1, 0, 32), (2, 0, 32))
RANDOM_CODES = (1, 2, 3, 4, 5, 6, 7, 8, 15, 16, 17, 22, 23, 43, 0x41, 0x80, 0xFF)


@dataclass
class LoadCount:
    """What the load did, to tell a quiet server from one that answered."""

    answers: int = 0
    random_frames: int = 0
    reconnects: int = 0
    errors: list[str] = field(default_factory=list)


def _mbap(transaction: int, pdu: bytes, unit: int = 1) -> bytes:
    return struct.pack(">HHHB", transaction & 0xFFFF, 0, len(pdu) + 1, unit) + pdu


async def _read_answer(reader: asyncio.StreamReader) -> bytes:
    header = await reader.readexactly(7)
    length = struct.unpack(">H", header[4:6])[0]
    return header + await reader.readexactly(max(0, length - 1))


async def poll(port: int, deadline: float, count: LoadCount) -> None:
    """One HMI-like client: read requests back to back over one connection until `deadline`."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    transaction = 0
    try:
        while time.monotonic() < deadline:
            for fc, address, quantity in POLLED:
                transaction += 1
                writer.write(_mbap(transaction, struct.pack(">BHH", fc, address, quantity)))
                await writer.drain()
                await asyncio.wait_for(_read_answer(reader), 5)
                count.answers += 1
    finally:
        writer.close()
        with contextlib.suppress(OSError):
            await writer.wait_closed()


def random_pdu(rng: random.Random) -> bytes:
    """A well-formed request the device may or may not serve (random addresses, quantities
    and values, function codes it does not serve), or now and then noise."""
    fc = rng.choice(RANDOM_CODES)
    if rng.random() < 0.02:
        return bytes([fc]) + rng.randbytes(rng.randrange(0, 12))
    if fc in (1, 2, 3, 4):
        return struct.pack(">BHH", fc, rng.randrange(0, 10000), rng.randrange(0, 2100))
    if fc in (5, 6):  # a coil, a macro call (holding 8), a variable, anything
        address = rng.choice((8, 8, 9, 300, 301, rng.randrange(0, 10000)))
        value = rng.choice((0, 0xFF00, rng.randrange(1, 158), rng.randrange(65536)))
        return struct.pack(">BHH", fc, address, value)
    if fc == 16:
        address = rng.choice((8000, 8000, 300, rng.randrange(0, 10000)))
        words = [rng.choice((2761, 2762, 3274, 3085, rng.randrange(65536)))]
        words += [rng.randrange(65536) for _ in range(rng.randrange(0, 8))]
        body = struct.pack(f">{len(words)}H", *words)
        return struct.pack(">BHHB", 16, address, len(words), len(body)) + body
    if fc == 15:
        quantity = rng.randrange(1, 64)
        body = rng.randbytes((quantity + 7) // 8)
        return struct.pack(">BHHB", 15, rng.randrange(0, 600), quantity, len(body)) + body
    return bytes([fc]) + rng.randbytes(rng.randrange(0, 6))  # a code the device lacks


async def shoot(port: int, deadline: float, seed: int, count: LoadCount) -> None:
    """One hostile client: random frames, each answer awaited (the server serves one request
    of a connection at a time), some cut short or followed by noise; it reconnects whenever
    the server closes the connection or leaves a frame unanswered."""
    rng = random.Random(seed)
    while time.monotonic() < deadline:
        try:
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
        except OSError as err:
            count.errors.append(repr(err))
            await asyncio.sleep(0.05)
            continue
        count.reconnects += 1
        try:
            while time.monotonic() < deadline:
                frame = _mbap(rng.randrange(65536), random_pdu(rng))
                if rng.random() < 0.02:
                    frame = frame[:rng.randrange(1, len(frame))]  # a half frame, then noise
                    frame += rng.randbytes(rng.randrange(0, 8))
                writer.write(frame)
                await writer.drain()
                count.random_frames += 1
                await asyncio.wait_for(_read_answer(reader), 0.5)
        except (TimeoutError, OSError, asyncio.IncompleteReadError):
            pass  # closed or left unanswered: a new connection
        finally:
            writer.close()
            with contextlib.suppress(OSError):
                await writer.wait_closed()


async def mixed_load(port: int, seconds: float, pollers: int = 20, shooters: int = 2,
                     seed: int = 1) -> LoadCount:
    """`pollers` polling clients and `shooters` random-frame clients for `seconds`."""
    count = LoadCount()
    deadline = time.monotonic() + seconds
    tasks = [poll(port, deadline, count) for _ in range(pollers)]
    tasks += [shoot(port, deadline, seed + k, count) for k in range(shooters)]
    results = await asyncio.gather(*tasks, return_exceptions=True)
    count.errors += [repr(r) for r in results if isinstance(r, BaseException)]
    return count


def rss_kib(pid: int) -> int:
    """The resident set size of process `pid` (Linux /proc), in KiB."""
    with open(f"/proc/{pid}/status", encoding="ascii") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise LookupError(f"no VmRSS for process {pid}")
