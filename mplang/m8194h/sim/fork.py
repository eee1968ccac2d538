"""A copy of a motion model to run ahead on (`fork`): what `MotionModel.idle_at` and
`AxisIO.next_interrupt` simulate to predict when axes come to rest or an interrupt falls due.

`copy.deepcopy` did this before, and through the run's stop watchers (`failure.
watch_axis_stops`) it copied the whole controller each time: most of a motion-heavy run went
into it. A fork copies only what running ahead changes, and shares what never changes once
built: a `_Motion` (a new motion replaces a running one, it is never altered), its profile
and every path but a chain's, the chip rules (frozen), the queued `_Cmd`s (compared by
identity), `_Plan`s, the plans kept by settings (`MotionModel._plans`, a cache whose key
is all its value depends on) and `_Seg`s, and the sensors and axis configuration, which only
commands change (a fork runs none: it only settles time forward; the axis settings are
copied, as a synchronous action may change a speed). A continuous interpolation's
`_ChainPath` grows as segments come in, so it is copied, and with it every motion, event
and home search that drives along it, keeping the sharing the original has (a chain's
motion is its axes' motion). The copy's stop watchers are removed: what a prediction meets
is not something the program did.

Most forks are taken where running ahead cannot change any of that (`_alone`: a STOP_WAIT
behind queued moves on a machine without sensors, interrupts or synchronous actions): only
the motions and the queue move, so the axis settings and the I/O status are shared too.

`FORKED` lists the attributes a fork knows for each class; a test keeps it equal to what the
classes hold, so a new mutable attribute cannot slip past the copy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeVar

from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.chains import _Chain
from mplang.m8194h.sim.io_state import _AxisStatus, _Event, _HomeRun
from mplang.m8194h.sim.paths import _ChainPath

if TYPE_CHECKING:
    from mplang.m8194h.sim.axis_io import AxisIO
    from mplang.m8194h.sim.motion import MotionModel

T = TypeVar("T")

FORKED: dict[str, frozenset[str]] = {
    "MotionModel": frozenset({
        "queue_capacity", "rules", "settings", "vector", "assigned", "_ax", "_queue", "_pending",
        "io",
        "_next_end", "_chains", "_chain_seq", "_open", "_plans"}),
    "AxisIO": frozenset({
        "model", "sensors", "cfg", "status", "now", "emergency", "emg_input", "int_enabled",
        "triggered", "requests", "_events", "_next", "_exempt", "_version", "_prediction",
        "_calm_known",
        "script", "script_next", "watches", "watch_above", "inpos_forced", "di_changes"}),
    "_AxisConfig": frozenset({
        "hlmt_plus_level", "hlmt_minus_level", "limit_stop_slow", "nhome_level", "home_level",
        "z_level", "alarm_enabled", "alarm_level", "inpos_enabled", "inpos_level", "slmt",
        "comp_plus", "comp_minus", "comp_ep", "hv", "home_limit", "home_steps", "home_offset",
        "int_factors", "sync_factors", "sync_targets", "action", "preset"}),
    "_AxisStatus": frozenset({
        "latched", "latch", "servo_on", "alarm_input", "in3_level", "mach_off", "home",
        "home_end", "raised"}),
    "_Chain": frozenset({
        "axes", "plan", "specs", "closed", "cmd", "started", "path", "end", "motion"}),
}
"""Per class, the attributes `fork` copies or shares on purpose."""


def _blank(obj: T) -> T:
    """A shallow copy without `copy.copy`'s reduce protocol (a fork is on the hot path;
    a copied dict is quicker than filling the new object's own)."""
    new: T = object.__new__(type(obj))
    new.__dict__ = obj.__dict__.copy()
    return new


class _Forker:
    """One fork: the copies made so far by identity, so shared objects stay shared."""

    def __init__(self) -> None:
        self.paths: dict[int, _ChainPath] = {}
        self.motions: dict[int, _Motion] = {}

    def path(self, path: _ChainPath) -> _ChainPath:
        new = self.paths.get(id(path))
        if new is None:
            new = _ChainPath()
            new.parts, new.offsets, new.length = list(path.parts), list(path.offsets), \
                path.length
            self.paths[id(path)] = new
        return new

    def motion(self, m: _Motion | None) -> _Motion | None:
        if m is None or type(m.path) is not _ChainPath:  # (it has no subclass)
            return m
        new = self.motions.get(id(m))
        if new is None:
            new = _blank(m)
            new.path = self.path(m.path)
            self.motions[id(m)] = new
        return new

    def chain(self, chain: _Chain) -> _Chain:
        new = _blank(chain)
        new.specs = list(chain.specs)
        new.path = self.path(chain.path)
        new.motion = self.motion(chain.motion)
        return new

    def event(self, event: _Event) -> _Event:
        moved = self.motion(event.motion)
        if moved is event.motion:
            return event
        new = _blank(event)
        new.motion = moved
        return new

    def home(self, run: _HomeRun | None) -> _HomeRun | None:
        if run is None:
            return None
        new = _blank(run)
        new.motion = self.motion(run.motion)
        return new

    def status(self, st: _AxisStatus) -> _AxisStatus:
        new = _blank(st)
        new.home = self.home(st.home)
        new.raised = None
        return new

    def io(self, io: AxisIO, model: MotionModel, alone: bool) -> AxisIO:
        new = _blank(io)
        new.model = model
        if alone:  # running ahead changes none of the lists and records below
            return new
        # sensors and cfg are shared: only commands change them, and a fork runs none
        new.status = [self.status(s) for s in io.status]
        new.triggered = list(io.triggered)
        new.requests = [_blank(r) for r in io.requests]
        new._events = [self.event(e) for e in io._events]
        new._exempt = [m for m in (self.motion(x) for x in io._exempt) if m is not None]
        # the machine's script (docs/machine.md): its changes and `when` conditions are
        # shared (set once by the machine file); what running ahead through them changes is
        # copied, and inputs the copy meets are not the controller's to apply
        new.watch_above = list(io.watch_above)
        new.inpos_forced = list(io.inpos_forced)
        new.di_changes = list(io.di_changes)
        return new

    def model(self, model: MotionModel) -> MotionModel:
        new = _blank(model)
        alone = _alone(model.io)
        if not alone:
            # a synchronous action may change a speed while running ahead (SET_ACTION preset 4)
            new.settings = [_blank(s) for s in model.settings]
            new.vector = _blank(model.vector)
        axes = []
        for ax in model._ax:
            copied = _blank(ax)
            m = ax.motion
            if m is not None and type(m.path) is _ChainPath:  # (as `motion` asks)
                copied.motion = self.motion(m)
            axes.append(copied)
        new._ax = axes
        new._queue = list(model._queue)
        new._pending = list(model._pending)
        if model._chains or model._open is not None:
            self.chains(model, new)
        else:
            new._chains = {}
        new.io = self.io(model.io, new, alone)
        return new

    def chains(self, model: MotionModel, new: MotionModel) -> None:
        """The continuous interpolations: each chain copied once, the open one among them."""
        chains = {cid: self.chain(c) for cid, c in model._chains.items()}
        new._chains = chains
        by_identity: dict[int, Any] = {id(old): chains[cid] for cid, old in
                                       model._chains.items()}
        opened = model._open
        new._open = None if opened is None else by_identity.get(id(opened)) or \
            self.chain(opened)


def _alone(io: AxisIO) -> bool:
    """Running ahead from here changes nothing but the motions, the queue and the I/O's
    own schedule (its time, version, events and calm answer, which `_blank` copies): no I/O
    event can come (calm, no event planned, no script, no motion exempt from limits), no
    interrupt can be asked for, no synchronous action can act (a drive's start and end are
    its only factors then), and a start cannot latch an error (no EMG input, no ALARM
    enabled). A home search is not calm, so none runs either."""
    if io.int_enabled or io.requests or io.emg_input or io.script or io.watches \
            or io._events or io._exempt:
        return False
    for cfg in io.cfg:
        if cfg.alarm_enabled or (cfg.sync_factors and cfg.sync_targets):
            return False
    return io._calm()


def fork(model: MotionModel) -> MotionModel:
    """An independent copy of `model` to run ahead on; the original is left as it is."""
    return _Forker().model(model)
