"""Drawing a `Trace` the way a motion controller's path-tracking window shows a run: the tool
path in the XY plane (and XZ / YZ when Z moves), and position and velocity against time for
every axis that moves. The trace comes from a family's run (`mplang.family.trace`): its
`unit` labels the axes.

matplotlib is driven through its object API on the Agg canvas, set explicitly: no pyplot,
no global backend, never a GUI window, and nothing that depends on a display. The image has
exactly the requested size in pixels (PNG) or that size at 100 dpi (SVG, in points), and the
same trace always gives the same bytes.
"""

from __future__ import annotations

import io
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from matplotlib import rc_context
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure, SubFigure
from matplotlib.ticker import MaxNLocator

from mplang.family.trace import Trace

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

DPI = 100
DEFAULT_WIDTH = 1200
DEFAULT_HEIGHT = 900
FORMATS = ("png", "svg")
TRUE_SCALE_RATIO = 10
"""A path panel is drawn to scale (one unit as long on both axes) unless one extent is more
than this many times the other; a flat Z move would otherwise be an invisible line."""

_STYLE: dict[RcKeyType, Any] = {
    "svg.hashsalt": "mplang",  # stable element ids: the same plot gives the same SVG
    "svg.fonttype": "path",  # text as outlines: no font needed where the SVG is viewed
    "agg.path.chunksize": 20_000,  # hundreds of thousands of samples draw without overflow
    "path.simplify": True,
    "font.size": 9,
    "axes.titlesize": 10,
}


@dataclass(frozen=True)
class PlotRequest:
    """What to draw and how big: `title` names the program and the run's outcome."""

    title: str
    fmt: str = "png"
    width: int = DEFAULT_WIDTH
    height: int = DEFAULT_HEIGHT


def render(trace: Trace, request: PlotRequest) -> bytes:
    """The plot of `trace` as PNG or SVG bytes."""
    if request.fmt not in FORMATS:
        raise ValueError(f"unknown image format {request.fmt!r}: use png or svg")
    if len(trace) == 0:
        raise ValueError("the trace has no samples")
    with rc_context(_STYLE), warnings.catch_warnings():
        # a small figure with many panels may not fit every label: it is still drawn
        warnings.filterwarnings("ignore", message=".*constrained_layout.*")
        warnings.filterwarnings("ignore", message=".*[Cc]onstrained layout.*")
        figure = build_figure(trace, request)
        buffer = io.BytesIO()
        metadata: dict[str, str | None] = {"Date": None} if request.fmt == "svg" else {}
        figure.savefig(buffer, format=request.fmt, dpi=DPI, metadata=metadata)
    return buffer.getvalue()


def build_figure(trace: Trace, request: PlotRequest) -> Figure:
    """The figure `render` saves, on its Agg canvas (tests read its panels and legends)."""
    figure = Figure(figsize=(request.width / DPI, request.height / DPI), dpi=DPI,
                    layout="constrained")
    FigureCanvasAgg(figure)
    figure.suptitle(request.title)
    _draw(figure, trace)
    return figure


def path_planes(trace: Trace) -> list[tuple[str, str]]:
    """XY always; XZ and YZ as well when Z moves."""
    planes = [("X", "Y")]
    if trace.moved("Z"):
        planes += [("X", "Z"), ("Y", "Z")]
    return planes


def _draw(figure: Figure, trace: Trace) -> None:
    moving = trace.moving_axes()
    rows = max(1, len(moving))
    changing = trace.changing_variables()
    ratios = [1.0, 0.55 + 0.25 * rows] + ([0.6] if changing else [])
    sections = figure.subfigures(len(ratios), 1, squeeze=False, height_ratios=ratios)
    top: SubFigure = sections[0, 0]
    bottom: SubFigure = sections[1, 0]
    if changing:
        _draw_variables(sections[2, 0].subplots(), trace, changing)
    planes = path_planes(trace)
    for panel, plane in zip(top.subplots(1, len(planes), squeeze=False)[0], planes,
                            strict=True):
        _draw_path(panel, trace, plane)
    if not moving:
        panel = bottom.subplots()
        panel.set_axis_off()
        panel.text(0.5, 0.5, "no axis moved during the run", ha="center", va="center",
                   transform=panel.transAxes)
        return
    grid = bottom.subplots(rows, 2, sharex=True, squeeze=False)
    for row, name in enumerate(moving):
        _draw_axis(grid[row][0], grid[row][1], trace, name)
    grid[0][0].set_title("position")
    grid[0][1].set_title("velocity")
    for panel in grid[-1]:
        panel.set_xlabel("time (s)")


MAX_VARIABLE_LINES = 8
"""The variables panel draws at most this many (the first that change); the CSV has all."""


def _draw_variables(panel: Axes, trace: Trace, changing: tuple[int, ...]) -> None:
    """The declared variables that change, against time, each labelled by its declared
    name and device number (`rows_done (VAR400)`)."""
    shown = changing[:MAX_VARIABLE_LINES]
    for index in shown:
        panel.step(trace.time, trace.values[index], where="post", linewidth=1.0,
                   label=trace.variables[index])
    more = len(changing) - len(shown)
    panel.set_title("variables" + (f" ({more} more in the trace)" if more else ""))
    panel.set_xlabel("time (s)")
    panel.grid(True, linewidth=0.4)
    panel.legend(loc="best", fontsize=7)


def _draw_path(panel: Axes, trace: Trace, plane: tuple[str, str]) -> None:
    across, up = plane
    xs = trace.lp[trace.axis(across)]
    ys = trace.lp[trace.axis(up)]
    panel.plot(xs, ys, linewidth=1.0, color="tab:blue")
    panel.plot(xs[:1], ys[:1], "o", color="tab:green", markersize=5, label="start")
    panel.plot(xs[-1:], ys[-1:], "x", color="tab:red", markersize=7, label="end")
    width = max(xs) - min(xs)
    height = max(ys) - min(ys)
    to_scale = min(width, height) * TRUE_SCALE_RATIO >= max(width, height)
    if to_scale:
        panel.set_aspect("equal", adjustable="datalim")
    panel.set_title(f"{across}{up} path" + ("" if to_scale else " (not to scale)"))
    panel.set_xlabel(f"{across} ({trace.unit})")
    panel.set_ylabel(f"{up} ({trace.unit})")
    panel.xaxis.set_major_locator(MaxNLocator(nbins=5))
    panel.grid(True, linewidth=0.4)
    panel.legend(loc="best", fontsize=7)


def _draw_axis(position: Axes, velocity: Axes, trace: Trace, name: str) -> None:
    index = trace.axis(name)
    lp, ep = trace.lp[index], trace.ep[index]
    position.plot(trace.time, lp, linewidth=1.0, label="LP")
    if ep != lp:
        position.plot(trace.time, ep, linewidth=0.8, linestyle="--", label="EP")
        position.legend(loc="best", fontsize=7)
    position.set_ylabel(f"{name} ({trace.unit})")
    velocity.plot(trace.time, trace.velocity[index], linewidth=1.0, color="tab:orange")
    velocity.set_ylabel(f"{name} ({trace.unit}/s)")
    for panel in (position, velocity):
        panel.grid(True, linewidth=0.4)
