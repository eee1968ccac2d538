"""Paths of the virtual M8194H's motions: where each axis is after a path length ``s``.

A motion is a profile ``s(t)`` (`profiles`) driving a path; a path maps ``s`` to the
positions of its axes (floats, in the axes' own frames) and gives their derivatives.  Here
are straight lines, arcs, chains of parts (one profile over several segments), the helix and
the parts of the rounded rectangle; the builders that lay them out from the axes' positions
are in `builders` and `chains`.

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``,
cited below as "manual line N"); where the manual is silent the choice is stated.

Conventions and simplifications
-------------------------------
* Arcs: axis 1 is the abscissa and axis 2 the ordinate of a right-handed plane;
  CCW means increasing polar angle, CW decreasing.  The manual's figure is not in
  the text (l.6675 only has its caption), so this is the usual mathematical sense.
  A finish point equal to the start (or on the start ray) means a full circle.  When
  the finish point is not exactly on the circle the radius is blended linearly along
  the sweep so the path stays continuous and still ends exactly on the finish point.
* The choices for RECTANGLE and HELIX_3D (the rectangle's points, the helix's centre and
  sense) are listed in `builders`, which lays both out from these parts.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from bisect import bisect_right

_TWO_PI = 2.0 * math.pi


class _Path(ABC):
    """Maps path length to axis positions (floats, in the axes' own frames)."""

    @abstractmethod
    def pos(self, k: int, s: float) -> float:
        """Position of path axis k after path length s."""

    @abstractmethod
    def deriv(self, k: int, s: float) -> float:
        """d(position of axis k)/d(path length) at s."""


class _LinePath(_Path):
    __slots__ = ("deltas", "length", "starts")

    def __init__(self, starts: tuple[int, ...], deltas: tuple[int, ...], length: float) -> None:
        self.starts = starts
        self.deltas = deltas
        self.length = length

    def pos(self, k: int, s: float) -> float:
        return self.starts[k] + self.deltas[k] * (s / self.length)

    def deriv(self, k: int, s: float) -> float:
        return self.deltas[k] / self.length


class _ArcPath(_Path):
    __slots__ = ("cx", "cy", "length", "r0", "r1", "sweep", "th0")

    def __init__(self, cx: float, cy: float, r0: float, r1: float, th0: float,
                 sweep: float) -> None:
        self.cx, self.cy, self.r0, self.r1 = cx, cy, r0, r1
        self.th0, self.sweep = th0, sweep
        self.length = abs(sweep) * (r0 + r1) / 2.0

    def pos(self, k: int, s: float) -> float:
        f = s / self.length
        th = self.th0 + self.sweep * f
        r = self.r0 + (self.r1 - self.r0) * f
        return self.cx + r * math.cos(th) if k == 0 else self.cy + r * math.sin(th)

    def deriv(self, k: int, s: float) -> float:
        f = s / self.length
        th = self.th0 + self.sweep * f
        r = self.r0 + (self.r1 - self.r0) * f
        dr = (self.r1 - self.r0) / self.length
        dth = self.sweep / self.length
        if k == 0:
            return dr * math.cos(th) - r * math.sin(th) * dth
        return dr * math.sin(th) + r * math.cos(th) * dth


def _arc_path(x0: int, y0: int, cx: int, cy: int, fx: int, fy: int, clockwise: bool,
              full: bool) -> _ArcPath | None:
    """The arc from (x0, y0) around (cx, cy) to (fx, fy); None if the radius is zero."""
    r0 = math.hypot(x0 - cx, y0 - cy)
    if r0 == 0.0:
        return None
    r1 = math.hypot(fx - cx, fy - cy)
    th0 = math.atan2(y0 - cy, x0 - cx)
    th1 = math.atan2(fy - cy, fx - cx) if r1 > 0.0 else th0
    sweep = ((th0 - th1) if clockwise else (th1 - th0)) % _TWO_PI
    if full or sweep < 1e-12:
        sweep = _TWO_PI
    return _ArcPath(cx, cy, r0, r1, th0, -sweep if clockwise else sweep)


class _ChainPath(_Path):
    """Parts joined end to end, so one profile drives a whole continuous interpolation."""

    __slots__ = ("length", "offsets", "parts")

    def __init__(self) -> None:
        self.parts: list[_Path] = []
        self.offsets: list[float] = []  # path length at the start of each part
        self.length = 0.0

    def add(self, part: _Path, length: float) -> None:
        self.offsets.append(self.length)
        self.parts.append(part)
        self.length += length

    def forget(self, s: float) -> None:
        """Drop the parts that end before the one holding path length `s` but one, so a
        chain that runs for ever keeps a bounded path.  Offsets stay absolute, so every
        length from the kept parts on maps exactly as before; the motion that drives the
        path never samples a length before `s` again (it only moves forward in time)."""
        drop = bisect_right(self.offsets, s) - 2
        if drop > 0:
            del self.parts[:drop]
            del self.offsets[:drop]

    def _at(self, s: float) -> tuple[_Path, float]:
        i = max(bisect_right(self.offsets, s) - 1, 0)
        return self.parts[i], s - self.offsets[i]

    def pos(self, k: int, s: float) -> float:
        part, ds = self._at(s)
        return part.pos(k, ds)

    def deriv(self, k: int, s: float) -> float:
        part, ds = self._at(s)
        return part.deriv(k, ds)


class _HelixPath(_Path):
    """A circle in the plane of path axes 0/1 while path axis 2 advances in proportion."""

    __slots__ = ("circle", "dz", "length", "z0")

    def __init__(self, circle: _ArcPath, z0: int, dz: int) -> None:
        self.circle = circle
        self.z0 = z0
        self.dz = dz
        self.length = math.hypot(circle.length, dz)

    def pos(self, k: int, s: float) -> float:
        f = s / self.length
        if k == 2:
            return self.z0 + self.dz * f
        return self.circle.pos(k, f * self.circle.length)

    def deriv(self, k: int, s: float) -> float:
        if k == 2:
            return self.dz / self.length
        scale = self.circle.length / self.length
        return self.circle.deriv(k, s * scale) * scale


# Tangent points of the rounded rectangle, in the frame of its bounding box (axis 1 along
# the length, axis 2 along the width, lower-left corner at the origin), numbered
# counter-clockwise from the left end of the lower side: these are Sp0-Sp7.  The edge from
# point k to point k+1 is a side for even k and a corner arc for odd k.
def _rectangle_parts(x0: int, y0: int, sp: int, clockwise: bool, lp: int, wp: int,
                     r: int) -> list[tuple[_Path, float]]:
    """Lines and arcs of one lap from tangent point `sp`, which is (x0, y0)."""
    pts = ((r, 0), (lp - r, 0), (lp, r), (lp, wp - r), (lp - r, wp), (r, wp), (0, wp - r),
           (0, r))
    centres = {1: (lp - r, r), 3: (lp - r, wp - r), 5: (r, wp - r), 7: (r, r)}
    ox, oy = x0 - pts[sp][0], y0 - pts[sp][1]
    step = -1 if clockwise else 1
    parts: list[tuple[_Path, float]] = []
    a = sp
    for _ in range(8):
        b = (a + step) % 8
        edge = a if step == 1 else b
        (xa, ya), (xb, yb) = pts[a], pts[b]
        if edge % 2 == 0:
            dx, dy = xb - xa, yb - ya
            length = math.hypot(dx, dy)
            if length > 0.0:
                parts.append((_LinePath((ox + xa, oy + ya), (dx, dy), length), length))
        else:
            cx, cy = centres[edge]
            arc = _arc_path(ox + xa, oy + ya, ox + cx, oy + cy, ox + xb, oy + yb, clockwise,
                            False)
            if arc is not None:
                parts.append((arc, arc.length))
        a = b
    return parts
