"""The device's bounded queues, as the interpreter meets them: the real-time command FIFO
(30 entries, RS 3729, input register 71) and the motion queue of commands that wait for
their axes (`MotionModel.queue_capacity`, profile `limits.motion_queue`).

A full FIFO refuses a new real-time command (`DeviceBusy`, exception 0x06). A full motion
queue refuses a new motion command (`QueueFull`, raised by the motion model before it
changes anything): a macro line then waits on a `Retry` and runs again, a real-time command
goes back to the head of the FIFO (`requeue`). So a program that outruns the axes runs at
their pace, and neither queue, nor the work of simulating it, grows with the time it runs.
"""

from __future__ import annotations

import dataclasses
import math
from bisect import bisect_right
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mplang.ir.catalogue import Command
from mplang.ir.macro import Operand
from mplang.m8194h.sim.builders import QueueFull
from mplang.m8194h.sim.chains import _chain_backlog, _reach_time

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController
    from mplang.m8194h.sim.motion import MotionModel

__all__ = ["DeviceBusy", "QueueFull", "QueuedCommand", "Retry", "requeue", "room_at"]


@dataclass
class QueuedCommand:
    """A real-time command in the DPRAM FIFO, executed at `due` on the simulated clock."""

    command: Command
    operands: tuple[Operand, ...]
    due: float


class DeviceBusy(Exception):
    """The real-time command FIFO is full: the device answers exception 0x06."""


class Retry:
    """The wait of a macro line whose motion command found the motion queue full: it ends
    when the queue may have room (`MotionModel.room_at`), and the line then runs again."""

    __slots__ = ("full", "vc")

    def __init__(self, vc: VirtualController, full: QueueFull) -> None:
        self.vc = vc
        self.full = full

    def __call__(self) -> float:
        return room_at(self.vc.motion, self.vc.clock, self.full.chain, self.full.needed)


def requeue(vc: VirtualController, queued: QueuedCommand, full: QueueFull) -> None:
    """A real-time motion command met a full motion queue: back to the head of the FIFO,
    due when the queue may have room; dropped (and logged) if nothing will make room, so
    the commands behind it (a DRV_START that releases held commands) still run."""
    room = room_at(vc.motion, vc.clock, full.chain, full.needed)
    if room == math.inf:
        vc.log.append(f"{vc.clock:.4f} s: {queued.command.name} dropped: the motion queue is "
                      "full of held commands")
        return
    vc.fifo.appendleft(dataclasses.replace(queued, due=max(room, vc.clock + vc.rtc_time)))


def room_at(model: MotionModel, now: float, chain: bool = False, needed: int = 1) -> float:
    """When a command refused with `QueueFull` (`chain`: a continuous segment; `needed`
    entries) should be tried again: `now` if there is room, else the next moment a waiting
    command can start or the open chain passes a segment end (inf: nothing will free it)."""
    model.settle(now)
    capacity = model.queue_capacity
    if capacity is None:
        return now
    next_end = model._next_end
    if chain:
        open_chain = model._open
        if open_chain is None or not model._chain_open(open_chain) or \
                _chain_backlog(open_chain, now) < capacity:
            return now
        m = open_chain.motion
        if not open_chain.started or m is None:
            return next_end
        s = m.prof.state(now - m.t0)[0]
        offsets = open_chain.path.offsets
        return min(_reach_time(m, offsets[bisect_right(offsets, s)]), next_end)
    waiting = model.waiting_commands()
    if not waiting or waiting + needed <= capacity:
        return now
    return next_end
