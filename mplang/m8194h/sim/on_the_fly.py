"""Changes to a running drive: SET_PULSE (7.1.10, change the target position on the fly) and
CHANGE_VEL_ON_FLY (9.13, change the drive speed of a running macro's drive).

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``, cited
as "RS N"); where the manual is silent the choice is stated here and in the device profile
(`[on_the_fly]` in stdlib/m8194h/device.toml).

* SET_PULSE sets the total pulses of the running fixed move (FIXED_MOVE or ABS_FIXED_MOVE,
  one axis) counted from where that move started, in its own direction: "Change the total
  pulses to 9000 pulses during fixed pulse moving" (RS 5505), "does not support change of
  the direction during driving" (RS 5477), data 0 ~ 2,000,000,000 (RS 5489). The rest of
  the move is replanned from the present position and speed (`profiles._retarget`) with
  the move's own speeds, so it still decelerates to SV and runs its offset pulses. A total
  the axis has already reached or passed ends the drive where it is now (the chip stops
  when its pulse count is reached). An axis that is idle, runs a continuous move, an
  interpolation or a home search is left alone (logged): there is no fixed move to change.
* CHANGE_VEL_ON_FLY sets the drive speed of the running single-axis drive (fixed or
  continuous) to the new speed, quantised to MAX_V/8000; "the drive will accelerate to the
  specified velocity" (RS 11011): it ramps there with the move's acceleration (down with
  its deceleration), and a fixed move still ends on its target, decelerating in time. The
  axis's SET_V setting is not changed: later moves run at the program's own speed. Idle
  axes, interpolations and home searches are left alone (logged).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from mplang.m8194h.sim.axes import AXES, _mask_axes, _round
from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.profiles import _Profile, _retarget

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel


def _single_drive(model: MotionModel, i: int) -> tuple[_Motion | None, str]:
    """The running single-axis drive of axis i (not an interpolation or home search), or
    None and why not."""
    m = model._ax[i].motion
    if m is None:
        return None, f"{AXES[i]} is not moving"
    if m.vector or len(m.axes) != 1:
        return None, f"{AXES[i]} runs an interpolation"
    if model.io.status[i].home is not None:
        return None, f"{AXES[i]} runs a home search"
    return m, ""


def set_pulse(model: MotionModel, axis_mask: int, total: int, now: float) -> list[str]:
    """SET_PULSE: the running fixed moves of the mask get `total` pulses. Returns, for
    the axes it did not change, why."""
    model.settle(now)
    notes: list[str] = []
    for i in _mask_axes(axis_mask):
        m, why = _single_drive(model, i)
        if m is None or m.continuous:
            notes.append(why or f"{AXES[i]} runs a continuous move")
            continue
        s, v, _a = m.prof.state(now - m.t0)
        if total <= s:  # reached or passed: the drive ends here and now
            prof = _Profile(s, 0.0)
            prof.length = s
            final = (_round(m.path.pos(0, s)),)
        else:
            prof = _retarget(s, v, float(total), m.plan)
            final = (_round(m.path.pos(0, float(total))),)
        model._ax[i].motion = _Motion(m.axes, now, prof, m.path, final, m.plan, False)
    model._recompute()
    model.settle(now)  # a drive that ends now ends now (D-END)
    return notes


def change_velocity(model: MotionModel, axis_mask: int, speed: int,
                    now: float) -> list[str]:
    """CHANGE_VEL_ON_FLY: the running single-axis drives of the mask change to `speed`.
    Returns, for the axes it did not change, why."""
    model.settle(now)
    notes: list[str] = []
    for i in _mask_axes(axis_mask):
        m, why = _single_drive(model, i)
        v = model.rules.speed(speed, model.settings[i].max_v)
        if m is None or v <= 0:
            notes.append(why or f"speed {speed} is not a drive speed")
            continue
        plan = replace(m.plan, v=v, sv=min(m.plan.sv, v), constant=False)
        if m.continuous:
            model._change_speed(i, m, plan, now)
            continue
        s, v0, _a = m.prof.state(now - m.t0)
        prof = _retarget(s, v0, m.prof.length, plan)
        model._ax[i].motion = _Motion(m.axes, now, prof, m.path, m.final, plan, False)
    model._recompute()
    return notes
