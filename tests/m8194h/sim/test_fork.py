"""The run-ahead copy of the motion model (`sim.fork`, behind STOP_WAIT's prediction and the
interrupt prediction of 7.3.10-13): it must behave exactly as a deep copy does and leave the
original alone, for every kind of state the model holds (single-axis moves, interpolation,
continuous-interpolation chains, home searches, limits, interrupt factors, held commands)."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.sim.builders import QueueFull
from mplang.m8194h.sim.chains import _Chain
from mplang.m8194h.sim.fork import FORKED, _alone, fork
from mplang.m8194h.sim.io_state import _AxisConfig, _AxisStatus
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.sim.scripted import InputChange, TimedChange, Watch
from mplang.m8194h.sim.signals import AxisSensors

X, Y, Z, U = 1, 2, 4, 8


def _command(model: MotionModel, kind: int, a: int, b: int, now: float) -> None:
    """One command of a generated program; values the model refuses are skipped."""
    axis = (X, Y, Z, U)[a % 4]
    try:
        match kind:
            case 0:
                model.fixed_move(axis, b, now)
            case 1:
                model.line((b, a * 37 - 500), now)
            case 2:
                model.arc((b // 2 or 1, 0), (b or 2, 0), a % 2 == 0, now)
            case 3:
                model.continuous_line((b, a * 11), a % 5 == 0, now)
            case 4:
                model.continuous_mix(1 + a % 5, (b // 3 or 1, 0), (b or 3, 0), a % 7 == 0,
                                     now)
            case 5:
                model.continue_move(axis, b * 3 or 500, now)
            case 6:
                model.stop(axis, now, a % 2 == 0)
            case 7:
                model.io.home_start(axis, now)
            case 8:
                model.io.intfactor_enable(axis, a % 8, 1 + a % 3, now)
                model.io.enable_int(now)
            case 9:
                model.hold(axis)
            case 10:
                model.start(axis, now)
            case 11:
                model.io.set_compare(axis, a % 2, 0, b, now)
            case 12:  # a start on one axis sets another's speed and may drive it
                other = (X, Y, Z, U)[(a + 1) % 4]
                model.io.set_preset(other, abs(b) % 50_000 + 100)
                model.io.sync_action(axis, other, 0xFF, a % 5, 0, 4, 0, 0, (0, 0, 0, 0), now)
            case _:
                model.intp_end(2, now)
    except (ValueError, QueueFull):
        pass


def _observe(model: MotionModel, now: float) -> tuple[object, ...]:
    """Everything a program or a register read can see of the model at `now`."""
    axes = tuple((model.lp(1 << i, now), model.ep(1 << i, now), round(model.cv(1 << i, now), 6),
                  model.axis_report(i, now)) for i in range(4))
    return axes, model.busy(15, now), model.waiting_commands(), \
        tuple(model.io.triggered_factors(now)), tuple(model.io.requests)


def _settings(model: MotionModel) -> tuple[object, ...]:
    """The model's settings and configuration as values (compared before and after a fork
    ran ahead: the original's must not move)."""
    return ([vars(s).copy() for s in model.settings], vars(model.vector).copy(),
            [repr(c) for c in model.io.cfg], [repr(s) for s in model.io.sensors],
            [(s.latched, s.latch, s.mach_off, s.home_end,
              None if s.home is None else (s.home.state, s.home.stopping))
             for s in model.io.status], list(model.io.triggered))


def _run_ahead(model: MotionModel, start: float, steps: int = 40) -> list[tuple[object, ...]]:
    """What the prediction loops do with a copy: from event to event, observing."""
    seen: list[tuple[object, ...]] = []
    t = start
    for _ in range(steps):
        nxt = model.next_event(t)
        if nxt is None or nxt > start + 60.0:
            break
        t = nxt
        model.settle(t)
        seen.append(_observe(model, t))
    seen.append(_observe(model, t + 0.25))
    return seen


program = st.lists(st.tuples(st.integers(0, 13), st.integers(0, 40),
                             st.integers(-30_000, 30_000), st.floats(0.0, 0.4)),
                   min_size=1, max_size=14)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(program)
def test_fork_runs_ahead_as_a_deep_copy_does_and_leaves_the_original(
        commands: list[tuple[int, int, int, float]]) -> None:
    model = MotionModel(queue_capacity=8)
    model.io.set_sensors(0, AxisSensors(limit_plus=40_000, limit_minus=-40_000), 0.0)
    model.set_v(15, 20_000)
    model.set_a(15, 200_000)
    model.set_vv(20_000)
    model.set_va(200_000)
    for axis in (X, Y, Z, U):
        model.io.set_home_mode(axis, 2, 1, 2, 0, 100)
        model.io.set_hv(axis, 2_000)
    now = 0.0
    for kind, a, b, pause in commands:
        now += pause
        _command(model, kind, a, b, now)
        before = copy.deepcopy(model)
        ahead = fork(model)
        reference = copy.deepcopy(model)
        assert _run_ahead(ahead, now) == _run_ahead(reference, now)
        assert _settings(model) == _settings(before)
        # the original was not touched: it runs ahead as the copy taken before the fork
        assert _run_ahead(copy.deepcopy(model), now) == _run_ahead(copy.deepcopy(before), now)
        assert model.idle_at(15, now) == copy.deepcopy(before).idle_at(15, now)
        assert model.io.next_interrupt(now) == copy.deepcopy(before).io.next_interrupt(now)


def _attributes(obj: object) -> frozenset[str]:
    return frozenset(vars(obj))


def test_fork_knows_every_attribute_of_the_state_it_copies() -> None:
    """A new attribute of the model's state must be added to `fork` (copied or shared on
    purpose): otherwise a prediction could change the running model through it."""
    model = MotionModel()
    chain = _Chain((0, 1), model._vector_plan())
    assert _attributes(model) == FORKED["MotionModel"]
    assert _attributes(model.io) == FORKED["AxisIO"]
    assert frozenset(f.name for f in dataclasses.fields(_AxisConfig)) == FORKED["_AxisConfig"]
    assert frozenset(f.name for f in dataclasses.fields(_AxisStatus)) == FORKED["_AxisStatus"]
    assert _attributes(chain) == FORKED["_Chain"]


def test_fork_drops_the_stop_watchers_of_the_run() -> None:
    """A limit the prediction reaches is not a stop of the program (failure.watch_axis_stops
    must not record it)."""
    model = MotionModel()
    raised: list[int] = []
    model.io.status[0].raised = raised.append
    model.io.set_sensors(0, AxisSensors(limit_plus=1_000), 0.0)
    model.set_v(X, 10_000)
    model.set_a(X, 100_000)
    model.fixed_move(X, 5_000, 0.0)
    ahead = fork(model)
    _run_ahead(ahead, 0.0)
    assert ahead.io.status[0].errors and not raised
    _run_ahead(model, 0.0)
    assert raised


def test_fork_runs_a_machine_script_ahead_without_touching_the_original() -> None:
    """A machine file's script (docs/machine.md): timed inputs and a `when` condition met
    while running ahead happen in the copy as in a deep copy, and the original keeps its
    place in the script, its condition states and its pending FRnet input changes."""
    model = MotionModel()
    model.io.load_script(
        [TimedChange(0.05, (InputChange("X.INPOS", 0, axis=0),)),
         TimedChange(0.2, (InputChange("DI8.3", 1, group=8, mask=1 << 3),))],
        [Watch(0, 5000, True, (InputChange("DI9", 0xFF, group=9, mask=0xFFFF),
                               InputChange("Y.INPOS", 1, axis=1)))], 0.0)
    model.fixed_move(X, 20_000, 0.0)
    before = copy.deepcopy(model)
    ahead = fork(model)
    assert _run_ahead(ahead, 0.0) == _run_ahead(copy.deepcopy(model), 0.0)
    assert ahead.io.script_next == 2 and ahead.io.watch_above == [True]
    assert len(ahead.io.di_changes) == 2 and ahead.io.inpos_forced[:2] == [False, True]
    # the original is where it was: its own run ahead meets the same script
    assert (model.io.script_next, model.io.watch_above, model.io.di_changes,
            model.io.inpos_forced) == (before.io.script_next, before.io.watch_above,
                                       before.io.di_changes, before.io.inpos_forced)
    assert _run_ahead(copy.deepcopy(model), 0.0) == _run_ahead(copy.deepcopy(before), 0.0)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(program)
def test_a_fork_sharing_settings_and_status_runs_ahead_as_a_deep_copy_does(
        commands: list[tuple[int, int, int, float]]) -> None:
    """On a machine without sensors or a home search most forks are `_alone`: they share the
    axis settings and the I/O status with the original. Running ahead on such a fork must
    still be what a deep copy does, and leave the shared records as they were."""
    model = MotionModel(queue_capacity=8)
    model.set_v(15, 20_000)
    model.set_a(15, 200_000)
    model.set_vv(20_000)
    model.set_va(200_000)
    now = 0.0
    for kind, a, b, pause in commands:
        now += pause
        if kind != 7:  # no home search: it would make every later fork a full copy
            _command(model, kind, a, b, now)
        before = copy.deepcopy(model)
        ahead = fork(model)
        assert (ahead.settings is model.settings) == _alone(model.io)
        assert _run_ahead(ahead, now) == _run_ahead(copy.deepcopy(model), now)
        assert _settings(model) == _settings(before)
        assert _run_ahead(copy.deepcopy(model), now) == _run_ahead(copy.deepcopy(before), now)
        assert model.idle_at(15, now) == copy.deepcopy(before).idle_at(15, now)


def test_a_fork_shares_only_where_running_ahead_cannot_change_the_shared_state() -> None:
    """A move queued behind another on a plain machine: the prediction's fork shares the
    settings and the I/O status. An interrupt factor, a synchronous action, an enabled ALARM
    or an EMG input can change them while running ahead: then they are copied."""
    model = MotionModel(queue_capacity=8)
    model.fixed_move(X, 5_000, 0.0)
    model.fixed_move(X, -5_000, 0.0)
    assert _alone(model.io)
    ahead = fork(model)
    assert ahead.settings is model.settings and ahead.io.status is model.io.status
    assert ahead._ax[0] is not model._ax[0] and ahead._queue is not model._queue
    end = model.idle_at(X, 0.0)
    assert end is not None and end > model._ax[0].motion.end  # type: ignore[union-attr]
    changes: list[Callable[[MotionModel], None]] = [
        lambda m: m.io.enable_int(0.0),
        lambda m: m.io.sync_action(X, Y, 0x20, 0, 0, 4, 0, 0, (0, 0, 0, 0), 0.0),
        lambda m: m.io.set_alarm(Y, 1, 1, 0.0),
        lambda m: m.io.set_emg_input(True, 0.0)]
    for change in changes:
        other = copy.deepcopy(model)
        change(other)
        assert not _alone(other.io)
        ahead = fork(other)
        assert ahead.settings is not other.settings and ahead.io.status is not other.io.status


def _fork_idle_at(model: MotionModel, axes: tuple[int, ...], now: float) -> float | None:
    """When the axes are idle, as a fork running ahead says (what `idle_at` asks of one)."""
    model.settle(now)
    return model._forked_idle_at(axes, now)


# moves, lines, arcs, continuous moves, stops, holds and starts close together: queues
queued = st.lists(st.tuples(st.sampled_from([0, 0, 0, 1, 1, 2, 2, 5, 6, 9, 10]),
                            st.integers(0, 40), st.integers(-30_000, 30_000),
                            st.sampled_from([0.0, 0.0, 0.01, 0.05, 0.3])),
                  min_size=1, max_size=14)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(queued, st.sampled_from([X, Y, Z, U, X | Y, Z | U, 15]))
def test_a_queue_drained_on_positions_alone_ends_when_a_fork_says(
        commands: list[tuple[int, int, int, float]], mask: int) -> None:
    """`MotionModel._drain` (STOP_WAIT's prediction where only motions end and queued
    commands start) gives the time a fork running ahead gives, and changes nothing."""
    model = MotionModel(queue_capacity=8)
    model.set_v(15, 20_000)
    model.set_a(15, 200_000)
    model.set_vv(20_000)
    model.set_va(200_000)
    axes = tuple(i for i in range(4) if mask >> i & 1)
    now = 0.0
    for kind, a, b, pause in commands:
        now += pause
        if kind != 7:
            _command(model, kind, a, b, now)
        model.settle(now)
        if not model._drains_alone():
            continue  # (a synchronous action, say: `idle_at` asks a fork, as before)
        expected = _fork_idle_at(copy.deepcopy(model), axes, now)
        before = copy.deepcopy(model)
        assert model.idle_at(mask, now) == expected
        assert _run_ahead(copy.deepcopy(model), now) == _run_ahead(before, now)


def test_a_queue_behind_a_line_is_drained_without_a_fork() -> None:
    """The bench job's case: an arc queued behind a line on a plain machine. Its end is
    worked out on the axes' positions (no fork), and is where the arc really ends."""
    model = MotionModel(queue_capacity=8)
    model.set_vv(20_000)
    model.line((2_000, 1_000), 0.0)
    model.arc((1_000, 0), (2_000, 0), True, 0.0)
    assert model._queue and model._drains_alone()
    end = model.idle_at(X, 0.0)
    assert end is not None and end == _fork_idle_at(copy.deepcopy(model), (0,), 0.0)
    model.settle(end)
    assert model._ax[0].motion is None and not model._queue
    assert (model.lp(X, end), model.lp(Y, end)) == (4_000, 1_000)
