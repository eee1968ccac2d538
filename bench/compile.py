"""Compiler throughput: a generated full-device image and a 512-line lint.

Targets (issue 2, printed, never asserted): the whole image (every MP and ISR slot filled to
its budget, about 5,800 lines) in under 0.5 s in a warm process; one 512-line file linted in
under 100 ms. Figures are also given as ratios to a baseline measured in the same run:
lark tokenising the same text, the floor any lark-based front end pays.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

from mplang.ir import catalogue
from mplang.lang.parser import _parser
from mplang.m8194h.compiler import compile_source

BODY = [
    "  SET_V X, 2000",
    "  VAR{n} = VAR1 + {n}",
    "  FIXED_MOVE XY, {n}",
    "  IF VAR{n} > 10",
    "    SET_A Y, 5000",
    "  END IF",
]


def program(kind: str, slot: int, lines: int) -> list[str]:
    """A program of exactly `lines` lines (the closing line included)."""
    out = [f"{kind.upper()} {slot}", "  VAR1 = 0"]
    body = lines - 2
    n = 0
    while body > 0:
        if body >= 3:
            for template in (BODY[3], BODY[4], BODY[5]):
                out.append(template.format(n=n % 400 + 2))
            body -= 3
        else:
            out.append(BODY[0])
            body -= 1
        n += 1
    out.append(f"END {kind.upper()}")
    return out


def full_device() -> tuple[str, int]:
    profile = catalogue.load().profile
    lines: list[str] = []
    total = 0
    for kind in ("mp", "isr"):
        for slot in profile.slot_numbers(kind):
            budget = profile.budget(kind, slot) or 0
            lines += program(kind, slot, budget)
            total += budget
    return "\n".join(lines) + "\n", total


def best_of(runs: int, action: Callable[[], object]) -> tuple[float, float]:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return min(times), statistics.median(times)


def main() -> None:
    source, device_lines = full_device()
    result = compile_source(source, "full.mp")  # warm-up, and a correctness check
    assert result.ok, result.diagnostics[:3]
    assert sum(p.placement.lines_used for p in result.programs) == device_lines
    lark, _builder = _parser()
    lex_best, _ = best_of(5, lambda: list(lark.lex(source)))
    build_best, build_median = best_of(5, lambda: compile_source(source, "full.mp"))
    mp156 = "\n".join(program("mp", 156, 512)) + "\n"
    lint_best, lint_median = best_of(20, lambda: compile_source(mp156, "one.mp"))
    print(f"full-device image: {len(result.programs)} programs, {device_lines} macro lines, "
          f"{source.count(chr(10))} source lines")
    print(f"  build: best {build_best * 1000:.0f} ms, median {build_median * 1000:.0f} ms "
          f"(target < 500 ms), {device_lines / build_best:,.0f} macro lines/s")
    print(f"  baseline, lark lexing the same text: {lex_best * 1000:.0f} ms "
          f"-> build = {build_best / lex_best:.1f}x lexing")
    print(f"512-line lint: best {lint_best * 1000:.1f} ms, median {lint_median * 1000:.1f} ms "
          f"(target < 100 ms)")


if __name__ == "__main__":
    main()
