"""Axis names, axis codes and pulse rounding, shared by the motion model and the axis I/O.

The four axes are indexed 0..3 (X, Y, Z, U).  Commands name them by Table-4 codes: a
single-axis code is 1, 2, 4 or 8, an axis mask any combination of them up to 15.  Positions
are whole pulses, rounded half up.  Both `motion` and the axis I/O modules need these, so
they sit in a module of their own below both.
"""

from __future__ import annotations

import math

AXES = ("X", "Y", "Z", "U")


def _round(x: float) -> int:
    """Round half up (monotonic, unlike banker's rounding it never favours evens)."""
    return math.floor(x + 0.5)


_MASK_AXES = {mask: tuple(i for i in range(4) if mask >> i & 1) for mask in range(1, 16)}


def _mask_axes(mask: int) -> tuple[int, ...]:
    """The axis indices of a mask (a table: every motion command asks)."""
    axes = _MASK_AXES.get(mask)
    if axes is None:
        raise ValueError(f"axis mask must be 1..15, got {mask}")
    return axes


def _axis_index(code: int) -> int:
    if code not in (1, 2, 4, 8):
        raise ValueError(f"single-axis code must be 1, 2, 4 or 8, got {code}")
    return code.bit_length() - 1
