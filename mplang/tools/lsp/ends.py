"""What two versions of a list share at their ends, found by identity.

The server keeps what it made for the last check (placements, their JSON text) in lists in
the order of the check's diagnostics. After an edit, nearly every diagnostic is the very
object it was (a program the edit left alone keeps its own), so the items both lists hold
at the same place from either end are found by comparing pointers in C, without reading
the objects (a whole device has thousands, spread over the heap): only the few in between
are looked at one by one.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import islice
from operator import is_


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
