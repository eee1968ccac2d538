"""Stored-line handlers for per-axis state: hold/start, stops and the axis error report.

Kept apart from the interpreter so the axis features (home search, limits, emergency
stop, compare and latch) grow without touching it; the controller merges
`handlers(controller)` into its dispatch table.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.ir import Operand

if TYPE_CHECKING:
    from mplang.sim.controller import Frame, Handler, VirtualController


def handlers(vc: VirtualController) -> dict[str, Handler]:
    motion = vc.motion

    def axis_call(action: str) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            mask = vc.value(ops[0])
            if action == "hold":
                motion.hold(mask)
            elif action == "start":
                motion.start(mask, vc.clock)
            else:
                motion.stop(mask, vc.clock, sudden=action == "sudden")
        return run

    def vector_stop(sudden: bool) -> Handler:
        def run(_f: Frame, _ops: tuple[Operand, ...]) -> None:
            motion.vector_stop(vc.clock, sudden=sudden)
        return run

    def returns_zero(_f: Frame, _ops: tuple[Operand, ...]) -> None:
        vc.return_value = 0  # no axis error source is modelled yet: nothing has failed

    return {
        "DRV_HOLD": axis_call("hold"), "DRV_START": axis_call("start"),
        "STOP_SLOWLY": axis_call("slow"), "STOP_SUDDENLY": axis_call("sudden"),
        "VSTOP_SLOWLY": vector_stop(False), "VSTOP_SUDDENLY": vector_stop(True),
        "GET_ERROR": returns_zero, "GET_ERROR_CODE": returns_zero,
    }
