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


def _large_program() -> list[str]:
    """One long MP of every kind of block (IF/ELSE, FOR/NEXT, WHILE, REPEAT, labels and
    jumps, reads before writes, a read and its SET_RVAR, SET_MAX_V changing what W111 says)
    between a CONST and a small called program: the text whose edits inside one program
    the statement-level reuse must follow."""
    body: list[str] = []
    for n in range(6):
        body += [f"  VAR{n + 10} = VAR{n + 2} + {n}",
                 f"  IF VAR{n + 3} > {n}",
                 "    SET_A X, 5000",
                 "  ELSE" if n % 2 else "    VAR1 = VAR1 + 1",
                 f"    FIXED_MOVE XY, {n * 100 + 7}",
                 "  END IF",
                 f"  FOR {n + 2}",
                 f"    IF VAR{n + 20} < 3",
                 "      EXIT FOR",
                 "    END IF",
                 "    SET_V X, 70001",
                 "  NEXT",
                 f"  LABEL spot{n}" if n % 3 == 0 else f"  SET_V Z, {n + 1}",
                 f"  SET_MAX_V X, {100000 + n * 20000}",
                 "  SET_A X, 123457",
                 "  GET_LP(X)",
                 f"  SET_RVAR VAR{n + 30}",
                 f"  GOTO spot{n - 2}" if n % 3 == 2 else "  CALL helper"]
    return ["CONST STEP = 7", "MP 156 long", *body,
            "  WHILE VAR40 < STEP", "    VAR40 = VAR40 + 1", "  END WHILE",
            "  REPEAT VAR41", "    SET_V Y, 3001", "  END REPEAT", "END MP",
            "MP 2 helper", "  SET_V Z, 2000", "END MP", ""]


LARGE = _large_program()
LARGE_POOL = sorted(set(LARGE) | {
    "  IF VAR9 > 2", "  ELSE", "  END IF", "  FOR 3", "  NEXT", "  LABEL spot9",
    "  GOTO spot9", "  GOTO spot3", "  WHILE VAR2 < 4", "  END WHILE", "  REPEAT 2",
    "  END REPEAT", "  EXIT FOR", "  SET_RVAR VAR5", "  VAR3 = 1", "  VAR20 = VAR21",
    "  SET_MAX_V X, 8000", "  SET_MAX_V XY, 200000", "  AXIS_ASSIGN Y, X, Z", "  EXIT",
    "  VAR1 = (1 +", "  CALL helper", "  IF VAR2 + 1 > VAR3 * 2", "  VAR7 = VAR8 * 3 - VAR9"})


def _warm_up() -> list[list[str]]:
    """Texts to build before a drawn sequence of edits of `LARGE`: `LARGE`, one number of
    its long program changed, and `LARGE` again. A program keeps its statements from its
    first edit on, so the drawn edits meet kept statements from their first step."""
    at = LARGE.index("  SET_V Z, 2")
    return [LARGE, [*LARGE[:at], "  SET_V Z, 9", *LARGE[at + 1:]], LARGE]


def _replace(line: str, by: str) -> tuple[int, int, int]:
    """The step of `changed` (with `LARGE_POOL`) that replaces the line at the place of
    `LARGE`'s first `line` by `by`."""
    return (1, LARGE.index(line), LARGE_POOL.index(by))


def changed(lines: list[str], step: tuple[int, int, int], pool: list[str] = POOL
            ) -> list[str]:
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
        out[row] = pool[pick % len(pool)]
    elif how == 2 and out:
        out.pop(row)
    elif how == 3:
        out.insert(row, pool[pick % len(pool)])
    elif how == 4 and len(out) > 1:
        other = (row + 1) % len(out)
        out[row], out[other] = out[other], out[row]
    return out


STEPS = st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5_000), st.integers(0, 5_000)),
                 min_size=1, max_size=6)


# Drawn sequences per test, besides the cases written out below (every one of which runs).
# Four test files use them, each comparing two builds or analyses per step: these numbers
# are most of their share of the suite's ten minutes (docs/testing.md).
EDIT_EXAMPLES = 50
LARGE_EDIT_EXAMPLES = 40


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
    decorated: Callable[..., None] = settings(max_examples=EDIT_EXAMPLES, deadline=None)(wrapped)
    return decorated


def large_edit_sequences(test: Callable[..., None]) -> Callable[..., None]:
    """`test(steps)` run on a drawn sequence of edits of `LARGE` (through `changed` with
    `LARGE_POOL`: block openers, closers, labels and jumps among the lines put in), and on
    cases that once broke reuse inside a program."""
    cases: list[list[tuple[int, int, int]]] = [
        [(0, 3, 0)],  # a number of one statement
        [(1, 4, LARGE_POOL.index("  END IF")), (2, 4, 0)],  # a block closed early, reopened
        [(3, 15, LARGE_POOL.index("  LABEL spot9")), (3, 2, LARGE_POOL.index("  GOTO spot9"))],
        [(0, 2, 0), (0, 2, 1)],  # a variable read before written, then not
        [(1, 14, LARGE_POOL.index("  SET_MAX_V X, 8000"))],  # W111 of every later statement
        # the read before a SET_RVAR replaced, and back: W106 of the unchanged SET_RVAR
        [_replace("  GET_LP(X)", "  VAR3 = 1"), _replace("  GET_LP(X)", "  GET_LP(X)")],
        # two temporaries given back in another order: later expressions take others
        # (the REPEAT's copy of its count)
        [_replace("  IF VAR3 > 0", "  IF VAR2 + 1 > VAR3 * 2")],
        # a WHILE above the program's WHILE (a stray END WHILE, then its opening) takes
        # the label the latter had
        [_replace("  SET_A X, 123457", "  END WHILE"),
         _replace("  SET_MAX_V X, 100000", "  WHILE VAR2 < 4")],
    ]
    wrapped: Any = test
    for steps in reversed(cases):
        wrapped = example(steps=steps)(wrapped)
    wrapped = given(steps=STEPS)(wrapped)
    decorated: Callable[..., None] = settings(max_examples=LARGE_EDIT_EXAMPLES,
                                              deadline=None)(wrapped)
    return decorated


LARGE_WARM_UP = _warm_up()


def changed_large(lines: list[str], step: tuple[int, int, int]) -> list[str]:
    """`changed` with the pool of `LARGE`'s edits (block openers, closers, labels, jumps)."""
    return changed(lines, step, LARGE_POOL)
