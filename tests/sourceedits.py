"""Edits of `.mp` sources for the tests that compare an incremental build or analysis
with one from scratch: the samples and check files, and steps of typing drawn by
hypothesis."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

if TYPE_CHECKING:
    from mplang.m8194h.compiler import BuildResult

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
CHECKS = sorted((ROOT / "tests" / "data" / "checks").glob("*.mp"))
FILES = [*SAMPLES, *CHECKS]
POOL = sorted({line for path in FILES for line in path.read_text(encoding="utf-8").split("\n")}
              | {"CONST SPEED = 7", "CONST SPEED = 2147483647 * 4", "VAR spare",
                 "ALIAS hits = VAR9", "  VAR450 = 1", "  CALL missing", "MP 9 extra",
                 "END MP", "  IF X >", "  NEXT"})


def seen(result: BuildResult) -> tuple[object, ...]:
    """All a build gives, to compare two builds: diagnostics, the image, frames with their
    lines, listing, map."""
    image = result.render("json") if result.ok else None
    listing = result.render("listing") if result.ok else None
    frames = [(p.placement.slot, p.frames, [(f.line.span, f.first_slot_line) for f in p.lines])
              for p in result.programs]
    return (result.diagnostics, image, listing, frames, result.variables, result.aliases,
            result.init.frames if result.init else None)


def changed(lines: list[str], step: tuple[int, int, int]) -> list[str]:
    """`lines` after one step of typing: a digit stepped (in any line, or in a line that
    declares what every program reads), a line replaced by, or a line inserted from, the
    pool (lines of every sample and check, and some that change what programs share:
    CONSTs, declared variables, names), a line dropped, two lines swapped."""
    how, at, pick = step
    out = list(lines)
    row = at % len(out) if out else 0
    if how == 5:
        shared = [i for i, line in enumerate(out)
                  if line.lstrip().upper().startswith(("CONST", "ALIAS", "VAR "))]
        how, row = 0, shared[at % len(shared)] if shared else row
    if how == 0 and out:
        digits = [i for i, c in enumerate(out[row]) if c.isdigit()]
        if digits:
            col = digits[pick % len(digits)]
            out[row] = out[row][:col] + str((int(out[row][col]) + 3) % 10) + out[row][col + 1:]
    elif how == 1 and out:
        out[row] = POOL[pick % len(POOL)]
    elif how == 2 and out:
        out.pop(row)
    elif how == 3:
        out.insert(row, POOL[pick % len(POOL)])
    elif how == 4 and len(out) > 1:
        other = (row + 1) % len(out)
        out[row], out[other] = out[other], out[row]
    return out


STEPS = st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5_000), st.integers(0, 5_000)),
                 min_size=1, max_size=6)


def edit_sequences(test: Callable[..., None]) -> Callable[..., None]:
    """`test(path, steps)` run on a sample or check file and a drawn sequence of edits, and
    on the cases that once broke reuse: CONSTs that every program reads, a program that
    only moved, lines inserted above every program."""
    cases: list[tuple[str, list[tuple[int, int, int]]]] = [
        ("expressions.mp", [(5, 0, 0), (5, 1, 1)]),  # CONSTs
        ("pick_and_place.mp", [(5, 2, 0), (0, 40, 1)]),
        ("call_chain.mp", [(2, 0, 0)]),  # every program moves up
        ("pick_and_place.mp", [(3, 0, 7), (3, 5, 9), (2, 1, 0)]),
    ]
    wrapped: Any = test
    for name, steps in reversed(cases):
        wrapped = example(path=ROOT / "samples" / name, steps=steps)(wrapped)
    wrapped = given(path=st.sampled_from(SAMPLES) | st.sampled_from(CHECKS), steps=STEPS)(wrapped)
    decorated: Callable[..., None] = settings(max_examples=50, deadline=None)(wrapped)
    return decorated
