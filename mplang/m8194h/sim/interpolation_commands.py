"""Stored-line handlers for interpolation: lines, arcs, circles, continuous interpolation
(lines, mixed lines and arcs), the rounded rectangle and the helix (manual 7.2, 7.4, 7.5.9).

Kept apart from the interpreter so the motion commands grow without touching it; the
controller merges `handlers(controller)` into its dispatch table (keys are mplang short
names, shared by the macro and the real-time form of a command).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.ir.macro import Operand

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, Handler, VirtualController


def handlers(vc: VirtualController) -> dict[str, Handler]:
    motion = vc.motion
    value = vc.value

    def values(ops: tuple[Operand, ...]) -> list[int]:
        """The operands' values: a plain int is its own (most are), a variable is read."""
        return [o if o.__class__ is int else value(o) for o in ops]

    def line(absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            motion.line(tuple(values(ops)), vc.clock, absolute=absolute)
        return run

    def arc(clockwise: bool, absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            v = values(ops)
            motion.arc((v[0], v[1]), (v[2], v[3]), clockwise, vc.clock, absolute=absolute)
        return run

    def circle(clockwise: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            motion.circle((vc.value(ops[0]), vc.value(ops[1])), clockwise, vc.clock)
        return run

    def initial(dims: int, with_mode: bool) -> Handler:
        # LINE_nD_INITIAL: axes, VSV, VV, VA (symmetric T-curve, VECTOR_SPEED 1 / 8);
        # MIX_2D_INITIAL: axes, nAcc (0 constant VV = mode 0, 1 T-curve = mode 1), speeds
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            v = values(ops)
            axes = tuple(v[:dims])
            if with_mode:
                mode = 1 if v[dims] else 0
                speeds = v[dims + 1:]
            else:
                mode = 8 if dims == 3 else 1
                speeds = v[dims:]
            motion.continuous_initial(axes, mode, speeds[0], speeds[1], speeds[2])
        return run

    def continuous_line(absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            v = values(ops)
            motion.continuous_line(tuple(v[1:]), v[0] == 1, vc.clock, absolute=absolute)
        return run

    def mix(absolute: bool) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            last, shape, cp1, cp2, fp1, fp2 = values(ops)
            motion.continuous_mix(shape, (cp1, cp2), (fp1, fp2), last == 1, vc.clock,
                                  absolute=absolute)
        return run

    def rectangle(_f: Frame, ops: tuple[Operand, ...]) -> None:
        a1, a2, n_acc, sp, n_dir, lp, wp, rp, rsv, rv, ra, rd = values(ops)
        motion.rectangle((a1, a2), n_acc == 0, sp, n_dir == 1, (lp, wp, rp),
                         (rsv, rv, ra, rd), vc.clock)

    def helix(_f: Frame, ops: tuple[Operand, ...]) -> None:
        a1, a2, a3, n_dir, vv, cp1, cp2, cycle, pitch = values(ops)
        # nDir 0 is CW, 1 CCW (l.8878) -- the reverse of RECTANGLE's nDir (l.8207)
        motion.helix((a1, a2, a3), n_dir == 0, vv, (cp1, cp2), cycle, pitch, vc.clock)

    def intp_end(_f: Frame, ops: tuple[Operand, ...]) -> None:
        motion.intp_end(3 if vc.value(ops[0]) == 1 else 2, vc.clock)

    return {
        "LINE_2D": line(False), "LINE_3D": line(False),
        "ABS_LINE_2D": line(True), "ABS_LINE_3D": line(True),
        "ARC_CW": arc(True, False), "ARC_CCW": arc(False, False),
        "ABS_ARC_CW": arc(True, True), "ABS_ARC_CCW": arc(False, True),
        "CIRCLE_CW": circle(True), "CIRCLE_CCW": circle(False),
        "RECTANGLE": rectangle, "HELIX_3D": helix, "INTP_END": intp_end,
        "LINE_2D_INITIAL": initial(2, False), "LINE_3D_INITIAL": initial(3, False),
        "MIX_2D_INITIAL": initial(2, True),
        "LINE_2D_CONTINUE": continuous_line(False), "LINE_3D_CONTINUE": continuous_line(False),
        "ABS_LINE_2D_CONTINUE": continuous_line(True),
        "ABS_LINE_3D_CONTINUE": continuous_line(True),
        "MIX_2D_CONTINUE": mix(False), "ABS_MIX_2D_CONTINUE": mix(True),
    }
