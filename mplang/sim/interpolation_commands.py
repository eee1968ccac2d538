"""Stored-line handlers for interpolation: lines, arcs and circles on the assigned axes.

Kept apart from the interpreter so the motion commands grow without touching it; the
controller merges `handlers(controller)` into its dispatch table (keys are mplang short
names, shared by the macro and the real-time form of a command).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.ir import Operand

if TYPE_CHECKING:
    from mplang.sim.controller import Frame, Handler, VirtualController


def handlers(vc: VirtualController) -> dict[str, Handler]:
    motion = vc.motion

    def line(absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            motion.line(tuple(vc.value(o) for o in ops), vc.clock, absolute=absolute)
        return run

    def arc(clockwise: bool, absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            v = [vc.value(o) for o in ops]
            motion.arc((v[0], v[1]), (v[2], v[3]), clockwise, vc.clock, absolute=absolute)
        return run

    def circle(clockwise: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            motion.circle((vc.value(ops[0]), vc.value(ops[1])), clockwise, vc.clock)
        return run

    return {
        "LINE_2D": line(False), "LINE_3D": line(False),
        "ABS_LINE_2D": line(True), "ABS_LINE_3D": line(True),
        "ARC_CW": arc(True, False), "ARC_CCW": arc(False, False),
        "ABS_ARC_CW": arc(True, True), "ABS_ARC_CCW": arc(False, True),
        "CIRCLE_CW": circle(True), "CIRCLE_CCW": circle(False),
    }
