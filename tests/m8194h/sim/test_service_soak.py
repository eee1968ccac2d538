"""`mpc sim` stays bounded under load: 20 HMI-like pollers and two clients sending random
frames leave its memory where it was after warming up, and no refused request is kept whole.

The growth this guards against: every refused request used to be kept, with the frames of
its traceback (about 2 KB each), so random frames grew the server by megabytes a second."""

from __future__ import annotations

import asyncio
import gc
import struct
import threading
import time
import tracemalloc
from pathlib import Path

from simload import mixed_load, rss_kib
from simproc import start_sim

from mplang.m8194h.modbus_server import REFUSALS_KEPT, DeviceFace
from mplang.m8194h.sim.controller import VirtualController

SAMPLES = sorted(str(p) for p in (Path(__file__).resolve().parents[3] / "samples").glob("*.mp"))

# Requests the device refuses, in the shapes `DeviceFace.action` receives them: a call of an
# empty MP slot, an unknown sub-function, a coil read past the table.
REFUSED = [(6, 8, 8, 1, [0], [5]), (16, 8000, 8000, 2, [0, 0], [9999, 1]),
           (1, 0, 5000, 10, [0] * 10, None)]


# Enough that a kept refusal of even 170 bytes (a whole one with its frames is ~2 KB) passes
# the 1 MB bound; more only makes tracemalloc slower.
REFUSALS_MEASURED = 6_000


def test_refused_requests_are_counted_but_only_the_latest_kept_without_frames() -> None:
    face = DeviceFace(VirtualController())

    async def refuse(times: int) -> None:
        for k in range(times):
            assert await face.action(*REFUSED[k % len(REFUSED)]) is not None

    asyncio.run(refuse(2 * REFUSALS_KEPT))  # warm up: the kept list is full from here on
    gc.collect()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        asyncio.run(refuse(REFUSALS_MEASURED))
        gc.collect()
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert face.refused == 2 * REFUSALS_KEPT + REFUSALS_MEASURED
    assert len(face.refusals) == REFUSALS_KEPT
    assert all(r.__traceback__ is None for r in face.refusals)
    assert grown < 1_000_000, (f"{REFUSALS_MEASURED:,} refused requests grew the device by "
                               f"{grown} bytes")


def test_served_simulator_memory_stays_flat_under_pollers_and_random_frames() -> None:
    """The issue's measure: RSS within 20% of its level after warming up, to the end."""
    proc, port = start_sim(*SAMPLES)
    samples: list[tuple[float, int]] = []
    start = time.monotonic()

    def sample() -> None:
        while proc.poll() is None and time.monotonic() - start < 25:
            samples.append((time.monotonic() - start, rss_kib(proc.pid)))
            time.sleep(1)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        count = asyncio.run(mixed_load(port, seconds=24, pollers=20, shooters=2))
        sampler.join()
        answer = asyncio.run(_read_positions(port))
    finally:
        proc.terminate()
        output = proc.communicate(timeout=20)[0]
    assert count.errors == [] and count.answers > 200 and count.random_frames > 100, count
    warm = [rss for t, rss in samples if t >= 8]
    assert len(warm) >= 10, samples
    assert max(warm) <= 1.2 * warm[0], f"RSS (KiB) over time: {samples}"
    assert answer[7] == 4 and answer[8] == 16  # still answering: FC4 with 8 registers' bytes
    assert "Traceback" not in output, output


async def _read_positions(port: int) -> bytes:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        writer.write(struct.pack(">HHHBBHH", 1, 0, 6, 1, 4, 26, 8))
        await writer.drain()
        return await asyncio.wait_for(reader.readexactly(9 + 16), 10)
    finally:
        writer.close()
