"""The pending waits of the lines that wait (STOP_WAIT, FRNET_WAIT): what `Frame.wait` holds.

A wait is asked whenever time moves (`VirtualController.advance`) and returns the simulated
time it ends, inf while that is not foreseeable, so a stop or an input change ends it early.
Each is a small slots class: STOP_WAIT is most of a motion job's waiting, asked after every
event, and keeps its answer until the motion model changes (`VirtualController.epoch`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController


class StopWait:
    """STOP_WAIT: until every axis of `mask` is idle. The answer is kept for the epoch it
    was predicted in (predicting it may simulate ahead)."""

    __slots__ = ("end", "epoch", "mask", "vc")

    def __init__(self, vc: VirtualController, mask: int) -> None:
        self.vc = vc
        self.mask = mask
        self.epoch = -1
        self.end = math.inf

    def __call__(self) -> float:
        vc = self.vc
        if self.epoch != vc.epoch:
            end = vc.motion.idle_at(self.mask, vc.clock)
            self.end = math.inf if end is None else end
            self.epoch = vc.epoch
        return self.end


class LevelWait:
    """FRNET_WAIT: until channel `channel` of FRnet group `group` reads `state`, or the
    deadline (inf: none). Inputs change only from outside (the simulator's API), which
    is seen when time moves."""

    __slots__ = ("channel", "deadline", "group", "state", "vc")

    def __init__(self, vc: VirtualController, group: int, channel: int, state: int,
                 deadline: float) -> None:
        self.vc = vc
        self.group = group
        self.channel = channel
        self.state = state
        self.deadline = deadline

    def __call__(self) -> float:
        vc = self.vc
        if ((vc.frnet[self.group] >> self.channel) & 1) == self.state:
            return vc.clock
        return self.deadline
