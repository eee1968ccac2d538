"""What two versions of a list share at their ends, found by identity.

The server keeps what it made for the last check (placements, their JSON text) in lists in
the order of the check's diagnostics. After an edit, nearly every diagnostic is the very
object it was (a program the edit left alone keeps its own), so the items both lists hold
at the same place from either end are found by comparing pointers in C, without reading
the objects (a whole device has thousands, spread over the heap): only the few in between
are looked at one by one. The same holds for the statements of a file the editor indexes
(`picked_again`): after an edit, the ones of the lines it left alone are where they were.
"""

from __future__ import annotations

import bisect
from array import array
from collections.abc import Sequence
from itertools import compress, islice
from operator import is_
from typing import TypeVar

T = TypeVar("T")


def same_ends(old: Sequence[object], new: Sequence[object]) -> tuple[int, int]:
    """How many items at the start, and then at the end, of `new` are the very objects that
    `old` holds at the same place from that end (the two counts never overlap)."""
    limit = min(len(old), len(new))
    head = list(map(is_, old, new))
    try:
        start = head.index(False)
    except ValueError:
        start = limit
    tail = list(islice(map(is_, reversed(old), reversed(new)), limit - start))
    try:
        end = tail.index(False)
    except ValueError:
        end = len(tail)
    return start, end


_STRIDE = 256
"""Lines compared at once while looking for the first and last difference (a slice
comparison runs in C)."""


def shared_lines(old: Sequence[str], new: Sequence[str]) -> tuple[int, int]:
    """How many lines at the start, and then at the end, the two texts have alike (by
    value: each check splits its text anew); the counts never overlap."""
    limit = min(len(old), len(new))
    start = 0
    for step in (_STRIDE, 16, 1):
        while start + step <= limit and old[start:start + step] == new[start:start + step]:
            start += step
    end = 0
    for step in (_STRIDE, 16, 1):
        while end + step <= limit - start and \
                old[len(old) - end - step:len(old) - end] == \
                new[len(new) - end - step:len(new) - end]:
            end += step
    return start, end


def shared_text_lines(old: str, new: str) -> tuple[int, int]:
    """`shared_lines` of the two texts' lines (split at "\\n" only), found on the texts
    themselves: their common start and end are looked for by halving (slices compared in
    C, a whole device's text copied about twice over), not line by line through two lists
    of thousands of strings each."""
    limit = min(len(old), len(new))
    low, high = 0, limit  # old[:low] == new[:low]; the common start ends in [low, high]
    while low < high:
        middle = (low + high + 1) // 2
        if old[low:middle] == new[low:middle]:
            low = middle
        else:
            high = middle - 1
    # whole lines: those ended by a line feed inside the common start, and the line it
    # stops in when that ends at the same place in both (a line feed, or both ends)
    start = old.count("\n", 0, low)
    if _ends_alike(old, new, low, low):
        start, lines_end = start + 1, low + 1
    else:
        lines_end = old.rfind("\n", 0, low) + 1
    low, high = 0, max(limit - lines_end, 0)  # the same from the ends, not into those lines
    while low < high:
        middle = (low + high + 1) // 2
        if old[len(old) - middle:len(old) - low] == new[len(new) - middle:len(new) - low]:
            low = middle
        else:
            high = middle - 1
    # whole lines: those begun by a line feed inside the common end, and the line it
    # stops in when that begins at the same place in both
    end = new.count("\n", len(new) - low) + \
        _starts_alike(old, new, len(old) - low, len(new) - low)
    return start, min(end, min(old.count("\n"), new.count("\n")) + 1 - start)


def _ends_alike(old: str, new: str, at_old: int, at_new: int) -> bool:
    """Whether the line that runs into `at` (in each text) ends there in both."""
    return (at_old == len(old) or old[at_old] == "\n") and \
        (at_new == len(new) or new[at_new] == "\n")


def _starts_alike(old: str, new: str, at_old: int, at_new: int) -> bool:
    """Whether the line that runs from `at` (in each text) starts there in both."""
    return (at_old == 0 or old[at_old - 1] == "\n") and \
        (at_new == 0 or new[at_new - 1] == "\n")


def picked(items: Sequence[T], kinds: frozenset[type]) -> tuple[list[T], array[int]]:
    """The items of exactly these classes, and where each stands: every item looked at (in
    C: a whole device's file has thousands of statements, and a pass wants a few)."""
    positions = array("l", compress(range(len(items)),
                                    map(kinds.__contains__, map(type, items))))
    return list(map(items.__getitem__, positions)), positions


def picked_again(items: Sequence[T], kinds: frozenset[type],
                 last: tuple[list[T], array[int], int], start: int, stop: int
                 ) -> tuple[list[T], array[int]] | None:
    """`picked` after an edit that may have changed `items[start:stop]` only, from the last
    `picked` (its items and positions, and how many items there were): the items between
    are looked at; the others are taken where they stood (those after the edit moved as far
    as the edit changed the count), checked to be the very objects there. None when one is
    not: then every item must be looked at."""
    kept, positions, count = last
    shift = len(items) - count
    before = bisect.bisect_left(positions, start)
    after = bisect.bisect_left(positions, stop - shift)
    moved = positions[after:] if not shift else array("l", map(shift.__add__, positions[after:]))
    if (moved and not 0 <= moved[-1] < len(items)) or \
            not all(map(is_, map(items.__getitem__, positions[:before]), kept[:before])) or \
            not all(map(is_, map(items.__getitem__, moved), kept[after:])):
        return None
    between = array("l", compress(range(start, stop),
                                  map(kinds.__contains__, map(type, items[start:stop]))))
    return ([*kept[:before], *map(items.__getitem__, between), *kept[after:]],
            positions[:before] + between + moved)
