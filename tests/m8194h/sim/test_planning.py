"""Planning on change only (`profiles.CHANGE_ONLY`): memoised point-to-point profiles and
plans, the kept answer of `AxisIO._calm`, and macro lines that run on after a motion command
when no event can come of it. Random motion programs run with it and with planning forced
afresh everywhere must give the same positions, speeds, states and times at every step."""

from __future__ import annotations

from changeonly import called, planning
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import preload

AXIS = st.sampled_from(["X", "Y", "Z", "U", "XY", "ZU", "XYZU"])
ONE_AXIS = st.sampled_from(["X", "Y", "Z", "U"])
PULSES = st.integers(-20_000, 20_000)
SPEED = st.integers(1_000, 120_000)
RATE = st.integers(20_000, 2_000_000)

# one macro line each; programs repeat some of them (a FOR loop), as jobs do
LINES = st.one_of(
    st.builds("SET_V {}, {}".format, AXIS, SPEED),
    st.builds("SET_SV {}, {}".format, AXIS, st.integers(0, 20_000)),
    st.builds("SET_A {}, {}".format, AXIS, RATE),
    st.builds("SET_D {}, {}".format, AXIS, RATE),
    st.builds("SET_K {}, {}".format, AXIS, st.integers(100_000, 50_000_000)),
    st.builds("NORMAL_SPEED {}, {}".format, AXIS, st.integers(0, 3)),
    st.builds("SET_AO {}, {}".format, AXIS, st.integers(0, 50)),
    st.builds("FIXED_MOVE {}, {}".format, AXIS, PULSES),
    st.builds("ABS_FIXED_MOVE {}, {}".format, AXIS, PULSES),
    st.builds("STOP_WAIT {}".format, ONE_AXIS),
    st.builds("CONTINUE_MOVE {}, {}".format, ONE_AXIS, st.integers(-60_000, 60_000)),
    st.builds("STOP_SLOWLY {}".format, AXIS),
    st.builds("STOP_SUDDENLY {}".format, AXIS),
    st.just("AXIS_ASSIGN X, Y, 0"),
    st.just("AXIS_ASSIGN Z, U, 0"),
    st.builds("VECTOR_SPEED {}".format, st.sampled_from([0, 1, 2, 3, 4])),
    st.builds("SET_VV {}".format, SPEED),
    st.builds("SET_VA {}".format, RATE),
    st.builds("LINE_2D {}, {}".format, PULSES, PULSES),
    st.builds("ARC_CW {}, {}, {}, {}".format, PULSES, PULSES, PULSES, PULSES),
    st.builds("CIRCLE_CCW {}, {}".format, PULSES, PULSES),
    st.builds("TIMER {}".format, st.integers(1, 40)),
    # compare interrupts: I/O events, so `_calm` changes its answer
    st.builds("SET_COMPARE X, 0, 0, {}".format, PULSES),
    st.just("INTFACTOR_ENABLE X, 4, 3"),
    st.just("INTFACTOR_DISABLE X, 4"),
    st.just("ENABLE_INT"),
    st.just("DISABLE_INT"),
)

ISR = """ISR 3
    VAR7 = VAR7 + 1
END ISR
"""


def program(head: list[str], body: list[str], count: int) -> str:
    lines = [f"    {line}" for line in head]
    lines += [f"    FOR {count}", *(f"        {line}" for line in body), "    NEXT"]
    return "MP 156\n" + "\n".join(lines) + "\nEND MP\n" + ISR


def steps(source: str, change_only: bool, lines_per_step: int) -> list[object]:
    """The state after every slice of `lines_per_step` macro lines (or 5 ms): time, lines
    run, every axis's LP, EP, signed speed and register report, the variables, the log."""
    seen: list[object] = []
    with planning(change_only):
        vc = called(source)
        for _ in range(400):
            ran = vc.advance(vc.clock + 0.005, max_steps=lines_per_step, until_idle=True)
            motion = vc.motion
            seen.append((vc.clock, ran, vc.epoch,
                         [motion.sample(i, vc.clock) for i in range(4)],
                         [motion.axis_report(i, vc.clock) for i in range(4)],
                         [motion.cv_reading(1 << i, vc.clock) for i in range(4)],
                         motion.next_event(vc.clock), motion.idle_at(15, vc.clock),
                         vc.vars[:8], vc.error, len(vc.log)))
            if not vc.stack and not ran:
                break
        seen.append(list(vc.log))
    return seen


# an ISR on a compare value of X, so that motions meet I/O events
ARMED = st.builds(lambda at: [f"SET_COMPARE X, 0, 0, {at}", "INTFACTOR_ENABLE X, 4, 3",
                              "ENABLE_INT"], st.integers(-5_000, 5_000))


@settings(max_examples=40, deadline=None)
@given(armed=st.one_of(st.just([]), ARMED), head=st.lists(LINES, max_size=5),
       body=st.lists(LINES, min_size=1, max_size=12), count=st.integers(1, 4),
       lines_per_step=st.integers(1, 9))
def test_change_only_planning_matches_planning_afresh(armed: list[str], head: list[str],
                                                      body: list[str], count: int,
                                                      lines_per_step: int) -> None:
    source = program(armed + head, body, count)
    assert steps(source, True, lines_per_step) == steps(source, False, lines_per_step)


def distinct_profiles(source: str, change_only: bool) -> int:
    """How many different profile objects axis X drove with, looked at after every line."""
    build = compile_source(source)
    seen: list[object] = []
    with planning(change_only):
        vc = VirtualController(word_order=build.word_order)
        preload(vc, build)
        vc.call(156)
        while vc.stack:
            vc.advance(vc.clock + 0.01, max_steps=1)
            m = vc.motion._ax[0].motion
            if m is not None and all(m.prof is not p for p in seen):
                seen.append(m.prof)
    return len(seen)


def test_a_repeated_move_shares_its_profile() -> None:
    """The memo is used: the second of two equal moves drives the first one's profile."""
    source = program(["SET_V X, 20000"], ["FIXED_MOVE X, 5000", "STOP_WAIT X"], 2)
    assert distinct_profiles(source, True) == 1
    assert distinct_profiles(source, False) == 2
