"""`mpc import` cost per megabyte of C at a few sizes (issue 19 item 7: linear in its input).

The C text is the repository's import samples (tests/data/import/*.c) repeated to each size,
so it holds everything the importer meets: comments, blank lines, #defines, host code, vendor
calls inside and outside programs, control flow. Printed, never asserted: seconds per MB at
each size and its ratio to the smallest size's. A linear importer keeps the ratio near 1;
a quadratic one doubles it with every doubling of the size.

Times are CPU seconds of this process (time.process_time), so a busy machine skews them
less. Run: `python bench/importc.py [MB ...]` (default 0.25 0.5 1).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from mplang.m8194h.importc import convert

SAMPLES = Path(__file__).resolve().parent.parent / "tests" / "data" / "import"
MB = 1_000_000


def c_text(size: int) -> str:
    """At least `size` characters of C: the samples, repeated whole."""
    unit = "\n".join(path.read_text(encoding="utf-8") for path in sorted(SAMPLES.glob("*.c")))
    copies = -(-size // len(unit))
    return "\n".join([unit] * copies)


def seconds(text: str) -> float:
    start = time.process_time()
    convert(text, source_name="bench.c")
    return time.process_time() - start


def main(argv: list[str]) -> None:
    sizes = [float(a) for a in argv] or [0.25, 0.5, 1.0]
    convert(c_text(10_000))  # warm-up: the catalogue, the regular expressions
    first: float | None = None
    for size in sizes:
        text = c_text(int(size * MB))
        megabytes = len(text.encode("utf-8")) / MB
        per_mb = seconds(text) / megabytes
        first = first or per_mb
        print(f"{megabytes:6.2f} MB of C: {per_mb:6.2f} s/MB, {per_mb / first:4.2f}x the "
              f"smallest size's s/MB")


if __name__ == "__main__":
    main(sys.argv[1:])
