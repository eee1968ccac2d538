"""Interpreter throughput and simulated-time speed (printed, never asserted).

Targets (issue 3): 1,000,000 macro lines/s on a loop-and-arithmetic program, and a 4-axis
job simulated at 1000x wall time. The baseline measured in the same run is a bare Python
loop doing the same arithmetic, the floor for any interpreter written in Python.
"""

from __future__ import annotations

import time

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import run_build

ARITH = """MP 156
  VAR1 = 0
  VAR2 = 0
  FOR 20000
    VAR1 = VAR1 + 3
    VAR2 = VAR1 * 2
    IF VAR2 > 1000
      VAR2 = VAR2 - 1000
    END IF
  NEXT
END MP
"""

JOB = """MP 156
  SET_V XYZU, 20000
  SET_A XYZU, 200000
  FOR 200
    FIXED_MOVE X, 5000
    FIXED_MOVE Y, -3000
    FIXED_MOVE Z, 1000
    FIXED_MOVE U, 700
    STOP_WAIT X
    STOP_WAIT Y
    STOP_WAIT Z
    STOP_WAIT U
    AXIS_ASSIGN X, Y, 0
    SET_VV 20000
    LINE_2D 2000, 1000
    ARC_CW 1000, 0, 2000, 0
    STOP_WAIT X
    STOP_WAIT Y
  NEXT
END MP
"""


def baseline(iterations: int) -> float:
    start = time.perf_counter()
    v1 = v2 = 0
    for _ in range(iterations):
        v1 += 3
        v2 = v1 * 2
        if v2 > 1000:
            v2 -= 1000
    return time.perf_counter() - start


def main() -> None:
    build = compile_source(ARITH)
    start = time.perf_counter()
    report = run_build(build)
    wall = time.perf_counter() - start
    lines = report.result.steps
    per_second = lines / wall
    base = baseline(20000)
    print(f"arithmetic loop: {lines:,} lines in {wall * 1000:.0f} ms = {per_second:,.0f} lines/s "
          f"(target 1,000,000); {wall / base:.0f}x a bare Python loop doing the same work")
    build = compile_source(JOB)
    start = time.perf_counter()
    report = run_build(build)
    wall = time.perf_counter() - start
    print(f"4-axis job: {report.result.time_s:.1f} s simulated in {wall * 1000:.0f} ms wall = "
          f"{report.result.time_s / wall:,.0f}x real time (target 1000x)")


if __name__ == "__main__":
    main()
