"""`mpc sim` memory under mixed load, the issue's full measure (printed, never asserted):
20 HMI-like pollers and two clients sending random frames for 60 s against a served virtual
controller with the samples loaded. The figure is the largest resident size from 10 s on as
a ratio of the size at 10 s (target: at most 1.20); the suite runs a 24 s version of it
(tests/m8194h/sim/test_service_soak.py)."""

from __future__ import annotations

import asyncio
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from simload import mixed_load, rss_kib  # noqa: E402
from simproc import start_sim  # noqa: E402

SECONDS = 60
WARM = 10


def main() -> None:
    proc, port = start_sim(*sorted(str(p) for p in (ROOT / "samples").glob("*.mp")))
    samples: list[tuple[float, int]] = []
    start = time.monotonic()

    def sample() -> None:
        while proc.poll() is None and time.monotonic() - start < SECONDS + 1:
            samples.append((time.monotonic() - start, rss_kib(proc.pid)))
            time.sleep(1)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        count = asyncio.run(mixed_load(port, SECONDS))
        sampler.join()
    finally:
        proc.terminate()
        proc.communicate(timeout=20)
    warm = [rss for t, rss in samples if t >= WARM]
    print(f"mpc sim under load, {SECONDS} s: {count.answers} polled answers, "
          f"{count.random_frames} random frames, {count.reconnects} connections")
    print(f"  RSS at {WARM} s {warm[0] / 1024:.1f} MiB, largest after {max(warm) / 1024:.1f} MiB:"
          f" {max(warm) / warm[0]:.3f}x (target <= 1.20x)")


if __name__ == "__main__":
    main()
