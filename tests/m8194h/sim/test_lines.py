"""A wait that ends before the slice's horizon ends inside the slice (`lines.run`,
`lines.ends_inside`): where nothing falls due before that horizon and no interrupt can come
(no machine script, no loading, no waiting ISR, `AxisIO.uneventful`), the interpreter moves
the clock to the wait's end and runs on instead of going back to `advance`. A STOP_WAIT on
axes already idle ends at once.

With `profiles.CHANGE_ONLY` off the interpreter always goes back to `advance`, so random
programs run both ways, with real-time commands from the FIFO, ISRs, FRnet DI triggers and
interrupts at the same clock, must give the same state after every slice."""

from __future__ import annotations

import pytest
from changeonly import called, planning
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.ir import catalogue
from mplang.ir.macro import MacroLine, Operand, VarRef
from mplang.lang.diagnostics import Span
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim import lines

CAT = catalogue.load()
ENC = Encoder(CAT)

AXIS = st.sampled_from(["X", "Y", "Z", "U", "XY", "ZU"])
ONE_AXIS = st.sampled_from(["X", "Y", "Z", "U"])
PULSES = st.integers(-4_000, 4_000)

# waits of every kind (on idle axes and busy ones), moves, and interrupts
LINES = st.one_of(
    st.builds("FIXED_MOVE {}, {}".format, AXIS, PULSES),
    st.builds("STOP_WAIT {}".format, ONE_AXIS),
    st.builds("STOP_WAIT {}".format, ONE_AXIS),
    st.builds("TIMER {}".format, st.integers(0, 6)),
    st.builds("FRNET_WAIT 8, {}, 1, {}".format, st.integers(0, 1), st.integers(1, 5)),
    st.builds("VAR3 = VAR3 + {}".format, st.integers(1, 9)),
    st.just("AXIS_ASSIGN X, Y, 0"),
    st.builds("LINE_2D {}, {}".format, PULSES, PULSES),
    st.builds("STOP_SLOWLY {}".format, AXIS),
    st.builds("SET_COMPARE X, 0, 0, {}".format, PULSES),
    st.just("INTFACTOR_ENABLE X, 4, 3"),
    st.just("ENABLE_INT"),
    st.just("DISABLE_INT"),
)

ISR = """ISR 3
    VAR7 = VAR7 + 1
    VAR6 = VAR7 * 2
END ISR
"""

# DI 8.0 off-to-on holds Z's drive (DRV_START in the program releases it); DI 8.1
# on-to-off aborts the command (every axis stops as STOP_SLOWLY stops it)
TRIGGERS = """TRIGGERS
    ON DI 8.0 OFF_TO_ON HOLD Z
    ON DI 8.1 ON_TO_OFF ABORT COMMAND
END TRIGGERS
"""

# between slices: a real-time command (it falls due inside the next slice), or a change of
# DI group 8, which the trigger table acts on
RTC = st.one_of(
    st.builds(lambda bits: ("DI", (bits,)), st.integers(0, 3)),
    st.builds(lambda v: ("WRITE_VAR", (VarRef(5), v)), st.integers(0, 99)),
    st.just(("MP_ISR_CALL", (3,))),
    st.builds(lambda a, p: ("FIXED_MOVE", (a, p)), st.sampled_from([1, 2, 4, 8]), PULSES),
)


def program(body: list[str], count: int) -> str:
    text = ["MP 156", "    SET_V XYZU, 20000", "    SET_A XYZU, 400000",
            f"    FOR {count}", *(f"        {line}" for line in body),
            "        DRV_START Z", "    NEXT", "END MP"]
    return "\n".join(text) + "\n" + ISR + TRIGGERS


def rtc(name: str, operands: tuple[Operand, ...]) -> list[int]:
    return ENC.frame(MacroLine(CAT.by_vendor["RSM_" + name], operands, Span("test", 1)))


def slices(source: str, shortcuts: bool, lines_per_step: int, step_s: float,
           writes: dict[int, tuple[str, tuple[Operand, ...]]]) -> list[object]:
    """The state after every slice of at most `lines_per_step` lines and `step_s` seconds,
    with `writes[n]` written to the FIFO before slice n."""
    seen: list[object] = []
    with planning(shortcuts):
        vc = called(source)
        for n in range(300):
            if n in writes:
                name, operands = writes[n]
                if name == "DI":
                    vc.set_di_group(8, int(operands[0]))
                else:
                    assert vc.write_subfunction(rtc(name, operands)) == 0
            ran = vc.advance(vc.clock + step_s, max_steps=lines_per_step, until_idle=True)
            motion = vc.motion
            seen.append((vc.clock, ran, vc.epoch, vc.chip_state, len(vc.fifo),
                         list(vc.isr_queue), [len(f.loops) for f in vc.stack],
                         [f.pc for f in vc.stack], [f.wait is None for f in vc.stack],
                         [motion.sample(i, vc.clock) for i in range(4)],
                         [motion.axis_report(i, vc.clock) for i in range(4)],
                         vc.vars[:8], vc.frnet[8], vc.error))
            if not vc.stack and not vc.fifo and not ran:
                break
        seen.append((list(vc.log), list(vc.triggers.fired)))
    return seen


@settings(max_examples=40, deadline=None)
@given(body=st.lists(LINES, min_size=1, max_size=10), count=st.integers(1, 3),
       lines_per_step=st.sampled_from([1, 3, 50, 10_000]),
       step_s=st.sampled_from([0.0005, 0.003, 0.05]),
       writes=st.dictionaries(st.integers(0, 40), RTC, max_size=4))
def test_waits_ending_inside_the_slice_match_going_back_to_advance(
        body: list[str], count: int, lines_per_step: int, step_s: float,
        writes: dict[int, tuple[str, tuple[Operand, ...]]]) -> None:
    source = program(body, count)
    assert slices(source, True, lines_per_step, step_s, writes) == \
        slices(source, False, lines_per_step, step_s, writes)


JOB = """MP 156
    SET_V XYZU, 20000
    SET_A XYZU, 200000
    FOR 5
        FIXED_MOVE X, 5000
        FIXED_MOVE Y, -3000
        STOP_WAIT X
        STOP_WAIT Y
        TIMER 3
    NEXT
END MP
"""


def slices_of_run(source: str, monkeypatch: pytest.MonkeyPatch) -> int:
    """How many slices of lines a whole run of `source` takes (one `lines.run` each)."""
    vc = called(source)
    count = 0
    run = lines.run

    def counted(*args: object) -> tuple[int, bool]:
        nonlocal count
        count += 1
        return run(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(lines, "run", counted)
    result = vc.run()
    assert result.finished, result.error
    return count


def test_a_motion_job_runs_in_one_slice(monkeypatch: pytest.MonkeyPatch) -> None:
    """Its STOP_WAITs (on moving axes and on idle ones) and TIMERs end inside the slice."""
    assert slices_of_run(JOB, monkeypatch) == 1
    with planning(False):
        # back to `advance` after every motion line and every wait
        assert slices_of_run(JOB, monkeypatch) == 1 + 2 + 5 * (2 + 3)


def test_fifo_commands_due_before_a_wait_ends_run_first() -> None:
    """On a served device the FIFO drains every 5 ms (profile
    `execution.served_rtc_command_time_us`): three WRITE_VARs fall due one by one while X
    moves, each at its time, before the STOP_WAIT ends; the line after it reads the last."""
    source = """MP 156
    SET_V X, 20000
    SET_A X, 200000
    FIXED_MOVE X, 5000
    STOP_WAIT X
    VAR1 = VAR5
END MP
"""
    vc = called(source)
    vc.rtc_time = int(CAT.profile.raw["execution"]["served_rtc_command_time_us"]) / 1e6
    for value in range(1, 4):
        assert vc.write_subfunction(rtc("WRITE_VAR", (VarRef(5), value))) == 0
    result = vc.run()
    assert result.finished, result.error
    assert vc.vars[1] == 3
    written = [entry.split(" s: ")[0] for entry in vc.log if "VAR5 =" in entry]
    assert written == ["0.0050", "0.0100", "0.0150"]  # X stops at 0.35 s
