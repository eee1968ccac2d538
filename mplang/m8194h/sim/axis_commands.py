"""Stored-line handlers for per-axis state: hold/start, stops, input settings, home search,
limits, emergency stop, errors, DI reads, compare, latch, synchronous actions, interrupts.

Kept apart from the interpreter so the axis features grow without touching it; the
controller merges `handlers(controller)` into its dispatch table (keys are mplang short
names, shared by the macro and the real-time form of a command). The behaviour lives in
`mplang.m8194h.sim.axis_io` (reached as ``vc.motion.io``); these handlers only decode operands.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from mplang.ir.macro import Operand
from mplang.m8194h.sim import on_the_fly
from mplang.m8194h.sim.axes import _axis_index

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, Handler, VirtualController


def handlers(vc: VirtualController) -> dict[str, Handler]:
    motion = vc.motion
    io = motion.io

    def values(ops: tuple[Operand, ...]) -> list[int]:
        return [vc.value(o) for o in ops]

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

    def timed(method: Callable[..., None]) -> Handler:
        """Operands in order, then the present time."""
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            method(*values(ops), vc.clock)
        return run

    def untimed(method: Callable[..., None]) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            method(*values(ops))
        return run

    def returns(getter: Callable[[list[int]], int]) -> Handler:
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            vc.return_value = int(getter(values(ops)))
        return run

    def report_bit(word: str) -> Callable[[list[int]], int]:
        """GET_DI / GET_DI_SIGNAL: bit nType of the status or signal word."""
        def get(v: list[int]) -> int:
            rep = motion.axis_report(_axis_index(v[0]), vc.clock)
            return (int(getattr(rep, word)) >> v[1]) & 1
        return get

    def report_word(word: str) -> Callable[[list[int]], int]:
        def get(v: list[int]) -> int:
            return int(getattr(motion.axis_report(_axis_index(v[0]), vc.clock), word))
        return get

    def set_action(_f: Frame, ops: tuple[Operand, ...]) -> None:
        v = values(ops)
        io.set_action(v[0], v[1], v[2], v[3], v[4], v[5], (v[6], v[7], v[8], v[9]))

    def sync_action(_f: Frame, ops: tuple[Operand, ...]) -> None:
        v = values(ops)
        io.sync_action(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7],
                       (v[8], v[9], v[10], v[11]), vc.clock)

    def on_fly(name: str, change: Callable[..., list[str]]) -> Handler:
        """SET_PULSE / CHANGE_VEL_ON_FLY (`on_the_fly`): axes it cannot change are logged."""
        def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
            mask, value = values(ops)
            for note in change(motion, mask, value, vc.clock):
                vc.log.append(f"{vc.clock:.4f} s: {name} {value}: no effect, {note}")
        return run

    def set_encoder(_f: Frame, ops: tuple[Operand, ...]) -> None:
        mask, _mode, _division, z_edge = values(ops)
        io.set_z_edge(mask, z_edge, vc.clock)

    return {
        # changes to a running drive (7.1.10, 9.13)
        "SET_PULSE": on_fly("SET_PULSE", on_the_fly.set_pulse),
        "CHANGE_VEL_ON_FLY": on_fly("CHANGE_VEL_ON_FLY", on_the_fly.change_velocity),
        "DRV_HOLD": axis_call("hold"), "DRV_START": axis_call("start"),
        "STOP_SLOWLY": axis_call("slow"), "STOP_SUDDENLY": axis_call("sudden"),
        "VSTOP_SLOWLY": vector_stop(False), "VSTOP_SUDDENLY": vector_stop(True),
        "CLEAR_STOP": timed(io.clear_stop), "CLEAR_VSTOP": timed(io.clear_vstop),
        # errors and states (4.8-4.12)
        "GET_ERROR": returns(lambda v: io.error_state(vc.clock)),
        "GET_ERROR_CODE": returns(lambda v: io.error_code(v[0], vc.clock)),
        "GET_HOME_SEARCH_STATE": returns(lambda v: io.home_state(v[0], vc.clock)),
        "GET_EMERGENCY_STATE": returns(lambda v: int(io.emergency)),
        "GET_STOP_STATUS": returns(report_word("stopped")),
        "GET_DI": returns(report_bit("di_status")),
        "GET_DI_ALL": returns(report_word("di_status")),
        "GET_DI_SIGNAL": returns(report_bit("di_signal")),
        "GET_DI_SIGNAL_ALL": returns(report_word("di_signal")),
        # input settings (3.5-3.13)
        "SET_HLMT": timed(io.set_hlmt), "LIMITSTOP_MODE": timed(io.set_limit_stop),
        "SET_NHOME": timed(io.set_nhome), "SET_HOME_EDGE": timed(io.set_home_edge),
        "SET_SLMT": timed(io.set_slmt), "CLEAR_SLMT": timed(io.clear_slmt),
        "SET_ALARM": timed(io.set_alarm), "SET_INPOS": timed(io.set_inpos),
        "SET_ENCODER": set_encoder,
        "SERVO_ON": untimed(lambda mask: io.servo(mask, True)),
        "SERVO_OFF": untimed(lambda mask: io.servo(mask, False)),
        # home search (chapter 6)
        "SET_HV": untimed(io.set_hv), "HOME_LIMIT": untimed(io.home_limit),
        "SET_HOME_MODE": untimed(io.set_home_mode), "HOME_START": timed(io.home_start),
        # emergency stop (7.5.10-7.5.11, real-time commands)
        "EMERGENCY_STOP": untimed(lambda stop_type: io.emergency_stop(stop_type == 0,
                                                                      vc.clock)),
        "CLEAR_EMERGENCY_STOP": timed(io.clear_emergency),
        # compare, latch, synchronous actions (7.3.1-7.3.8)
        "SET_COMPARE": timed(io.set_compare),
        "GET_LATCH": returns(lambda v: io.latch(v[0], vc.clock)),
        "SET_ACTIVATION_FACTORS": timed(io.set_activation_factors),
        "SET_ACTIVATION_AXIS": timed(io.set_activation_axis),
        "SET_ACTION": set_action, "SYNC_ACTION": sync_action,
        "CLEAR_SYNC_ACTION": timed(io.clear_sync_action),
        "SET_PRESET": untimed(io.set_preset),
        # interrupts (7.3.10-7.3.13, 4.15)
        "ENABLE_INT": timed(io.enable_int), "DISABLE_INT": timed(io.disable_int),
        "INTFACTOR_ENABLE": timed(io.intfactor_enable),
        "INTFACTOR_DISABLE": timed(io.intfactor_disable),
        "GET_TRIG_INTFACTOR": returns(lambda v: io.triggered_factors(vc.clock)[v[0]]),
    }
