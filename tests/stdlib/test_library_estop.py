"""std:estop.mp on the virtual controller: the EMG input, a limit switch or the host's
EMERGENCY_STOP stop the axes; the D-END interrupt then runs std_estop_isr, which makes the
outputs safe, records the cause and ends the running program. Stops a program gives itself
do not trip it, and std_estop_reset re-arms only once the cause is gone."""

from __future__ import annotations

from functools import cache

from library_support import Variables, X, Y, build, consts, load, lp, run, slot

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.axis_io import AxisSensors
from mplang.m8194h.sim.controller import VirtualController

SAFE = 0x0008  # alarm lamp on, everything else off
RUNNING = 0x0013  # spindle and valves on


@cache
def program() -> BuildResult:
    return build(consts(STD_ESTOP_DO_GROUP=0, STD_ESTOP_DO_SAFE=SAFE) + f"""
INCLUDE "std:estop.mp"
ALIAS reached = VAR1

MP 100 cycle
    SET_MAX_V XYZU, 80000
    SET_SV XYZU, 1000
    SET_V XYZU, 20000
    SET_A XYZU, 200000
    CALL std_estop_arm
    FRNET_OUT 0, {RUNNING}
    reached = 0
    FIXED_MOVE X, 100000
    FIXED_MOVE Y, 50000
    STOP_WAIT X
    STOP_WAIT Y
    reached = 1
    FIXED_MOVE X, -100000
    STOP_WAIT X
    reached = 2
END MP

MP 101 stops_itself
    SET_MAX_V X, 80000
    CALL std_estop_arm
    CONTINUE_MOVE X, 5000
    TIMER 500
    STOP_SLOWLY X
    STOP_WAIT X
    reached = 1
END MP
""")


def started(sensors: AxisSensors | None = None) -> tuple[VirtualController, Variables]:
    """The cycle called and run for one second (X and Y on their way)."""
    result = program()
    vc = load(result, {0: sensors} if sensors else None)
    vc.call(slot(result, "cycle"))
    vc.advance(1.0)
    assert vc.vars[1] == 0 and vc.motion.busy(X | Y, vc.clock)
    return vc, Variables(result, vc)


def finish(vc: VirtualController) -> None:
    outcome = vc.run()
    assert outcome.finished, outcome.error


def test_a_cycle_without_trouble_is_left_alone() -> None:
    result = program()
    vc = load(result)
    run(vc, result, "cycle")
    variables = Variables(result, vc)
    assert vc.vars[1] == 2  # every line ran
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (0, 0)
    assert vc.frnet[0] == RUNNING
    assert (lp(vc, X), lp(vc, Y)) == (0, 50_000)


def test_the_emg_input_trips_it() -> None:
    vc, variables = started()
    stopped_at = (lp(vc, X), lp(vc, Y))
    vc.motion.io.set_emg_input(True, vc.clock)
    vc.touch()
    finish(vc)
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (1, 32)
    assert vc.frnet[0] == SAFE
    assert vc.vars[1] == 0  # the cycle ended where it waited
    assert (lp(vc, X), lp(vc, Y)) == stopped_at  # a sudden stop, and no move after it


def test_a_limit_switch_trips_it_and_other_axes_finish_their_move() -> None:
    vc, variables = started(AxisSensors(limit_plus=60_000, near_home=None, home=None,
                                        index_period=None))
    finish(vc)
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (1, 4)
    assert vc.frnet[0] == SAFE
    assert vc.vars[1] == 0
    # X stopped on its switch; Y's move was already under way: an ISR cannot stop it
    assert (lp(vc, X), lp(vc, Y)) == (60_000, 50_000)


def test_a_stop_the_program_gives_itself_does_not_trip_it() -> None:
    result = program()
    vc = load(result)
    run(vc, result, "stops_itself")
    variables = Variables(result, vc)
    assert vc.vars[1] == 1
    assert vc.motion.io.error_code(X, vc.clock) == 256  # SOFT STOP, ignored
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (0, 0)


def test_reset_waits_until_the_cause_is_gone() -> None:
    vc, variables = started()
    vc.motion.io.set_emg_input(True, vc.clock)
    vc.touch()
    finish(vc)
    result = program()
    run(vc, result, "std_estop_reset")
    assert variables["std_estop_tripped"] == 1  # EMG still pressed
    vc.motion.io.set_emg_input(False, vc.clock)
    run(vc, result, "std_estop_reset")
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (0, 0)
    assert vc.motion.io.error_state(vc.clock) == 0


def test_the_hosts_emergency_stop_while_idle_trips_it_through_mp_isr_call() -> None:
    result = program()
    vc = load(result)
    run(vc, result, "stops_itself")  # armed, axes idle
    vc.motion.io.emergency_stop(True, vc.clock)  # the host's EMERGENCY_STOP: no D-END now
    variables = Variables(result, vc)
    assert variables["std_estop_tripped"] == 0
    vc.request_isr(slot(result, "std_estop_isr"))  # the host's MP_ISR_CALL
    finish(vc)
    assert (variables["std_estop_tripped"], variables["std_estop_cause"]) == (1, 512)
    assert vc.frnet[0] == SAFE
    run(vc, result, "std_estop_reset")
    assert variables["std_estop_tripped"] == 1  # until CLEAR_EMERGENCY_STOP
    vc.motion.io.clear_emergency(vc.clock)
    run(vc, result, "std_estop_reset")
    assert variables["std_estop_tripped"] == 0
