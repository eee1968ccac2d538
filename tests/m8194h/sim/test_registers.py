"""The register map of the virtual M8194H, read and written directly (no Modbus transport).

Addresses and meanings are the manual's appendix 12; every expectation below says which
table it comes from.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mplang.ir import catalogue
from mplang.ir.macro import MacroLine, Operand, VarRef
from mplang.lang.diagnostics import Span
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import (
    DEVICE_BUSY,
    ILLEGAL_ADDRESS,
    ILLEGAL_FUNCTION,
    ILLEGAL_VALUE,
    Refusal,
    RegisterMap,
)

CAT = catalogue.load()


def rtc(name: str, *operands: Operand, word_order: int = 0) -> list[int]:
    """The FC16 frame of a real-time command, built by the encoder from the catalogue."""
    command = CAT.by_vendor["RSM_" + name]
    return Encoder(CAT, word_order).frame(MacroLine(command, operands, Span("test", 1)))


def download(regs: RegisterMap, source: str) -> None:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    for program in build.programs:
        for frame in program.frames:
            regs.write_holding(8000, frame)


def fresh() -> tuple[VirtualController, RegisterMap]:
    vc = VirtualController()
    return vc, RegisterMap(vc)


def refusal(action: object, *args: object) -> Refusal:
    with pytest.raises(Refusal) as caught:
        action(*args)  # type: ignore[operator]
    return caught.value


def test_download_through_the_window_reports_status_in_110_to_114() -> None:
    vc, regs = fresh()
    download(regs, "MP 21\n VAR1 = 7\nEND MP\n")
    assert regs.read_input(110, 5) == [21, 0, 0, 0, 0]
    assert regs.read_input(100, 3) == [0, 7, 0]  # ready; download finished; no error
    # a table the device must refuse on its own: NEXT without FOR (download error 0x09)
    regs.write_holding(8000, [0x0AC9, 41])
    assert regs.read_input(100, 1) == [1]  # MP download state (appendix table 12)
    # refused as it arrives with cause 0xB7 (RS 11368), the download fails (issue 13)
    assert refusal(regs.write_holding, 8000, [0x0CD6]).cause == 0xB7
    assert regs.read_input(102, 1) == [0xB7]
    regs.write_holding(8000, [0x0CCA])
    assert regs.read_input(110, 5) == [41, 0, 0x0CD6, 0, 0x09]
    assert ("mp", 41) not in vc.tables


def test_call_register_runs_the_program_and_vars_read_back_in_both_word_orders() -> None:
    vc, regs = fresh()
    download(regs, "MP 21\n VAR1 = -2\n VAR511 = 70000\nEND MP\n")
    regs.write_holding(8, [21])
    assert regs.read_input(101, 1) == [8]  # an MP is executing
    assert regs.read_input(24, 1) == [21]  # the running program's number
    assert regs.read_holding(8, 1) == [21]
    vc.advance(vc.clock + 0.01)
    assert regs.read_input(101, 1) == [9]  # execution finished
    assert regs.read_holding(302, 2) == [0xFFFF, 0xFFFE]  # MSW first by default
    assert regs.read_holding(1322, 2) == [0x0001, 0x1170]
    regs.write_holding(14, [1])
    assert regs.read_holding(302, 2) == [0xFFFE, 0xFFFF]  # LSW first
    regs.write_holding(304, [5, 0])
    assert vc.vars[2] == 5


def test_refusals_carry_the_register_102_cause() -> None:
    vc, regs = fresh()
    assert refusal(regs.write_holding, 8, [21]).cause == 0x02  # MP21 is empty
    assert refusal(regs.write_holding, 8000, [0x0C4E, 1, 0, 5]).cause == 0x08  # macro as RTC
    assert regs.read_input(102, 1) == [0x08]
    # a 32-bit value cut in half: exception 2 (Table 3, RS 939) and cause 0xC0 (RS 11368)
    half = refusal(regs.write_holding, 301, [1, 2])  # VAR0's low word and VAR1's high word
    assert (half.code, half.cause) == (ILLEGAL_ADDRESS, 0xC0)
    assert regs.read_input(102, 1) == [0xC0]
    cut = refusal(regs.read_input, 27, 2)  # from the LSW of X's LP to the MSW of Y's
    assert (cut.code, cut.cause) == (ILLEGAL_ADDRESS, 0xC0)
    assert refusal(regs.read_holding, 300, 3).cause == 0xC0
    assert regs.read_input(24, 4) == [0, 0, 0, 0]  # whole pairs from a single register on
    assert refusal(regs.write_holding, 14, [2]).code == ILLEGAL_VALUE
    assert refusal(regs.read_input, 199, 2).code == ILLEGAL_ADDRESS
    assert refusal(regs.write_holding, 106, [0, 0]).code == ILLEGAL_ADDRESS  # CV is read-only
    assert refusal(regs.write_holding, 8001, [1]).code == ILLEGAL_ADDRESS
    download(regs, "MP 21\n TIMER 1000\nEND MP\n")
    regs.write_holding(8, [21])
    running = refusal(regs.write_holding, 8, [21])
    assert (running.code, running.cause) == (ILLEGAL_FUNCTION, 0xC3)
    assert refusal(regs.write_holding, 8000, [0x0AC9, 22]).cause == 0xC3  # no download now
    assert vc.running


def test_full_fifo_answers_busy_and_drains_on_the_clock() -> None:
    vc, regs = fresh()
    for _ in range(30):
        regs.write_holding(8000, rtc("SET_V", 1, 5000))
    assert regs.read_input(71, 1) == [0]  # FREE_BUFFER_SIZE
    assert refusal(regs.write_holding, 8000, rtc("SET_V", 1, 5000)).code == DEVICE_BUSY
    vc.advance(vc.clock + 30 * vc.rtc_time + 1e-9)
    assert regs.read_input(71, 1) == [30]
    regs.write_holding(8000, rtc("SET_V", 1, 5000))


def test_real_time_commands_move_axes_and_write_variables() -> None:
    vc, regs = fresh()
    regs.write_holding(8000, rtc("FIXED_MOVE", 1, -4000))
    regs.write_holding(8000, rtc("WRITE_VAR", VarRef(9), 123))
    vc.advance(vc.clock + 0.001)
    assert regs.read_input(58, 1) == [0]  # X is moving (stop status, appendix table 5)
    assert regs.read_discrete(128, 1) == [True]  # DRIVING (appendix table 25)
    vc.advance(vc.clock + 5.0)
    assert regs.read_input(26, 2) == [0xFFFF, 0xF060]  # LP of X = -4000
    assert regs.read_input(160, 2) == [0xFFFF, 0xF060]
    assert regs.read_input(58, 1) == [1] and regs.read_discrete(128, 1) == [False]
    assert vc.vars[9] == 123


def test_positions_can_be_written_through_holding_registers() -> None:
    vc, regs = fresh()
    regs.write_holding(92, [0, 1234])  # LP of Y
    regs.write_holding(102, [0xFFFF, 0xFFFF])  # EP of Z = -1
    assert vc.motion.lp(2, vc.clock) == 1234
    assert vc.motion.ep(4, vc.clock) == -1
    assert regs.read_input(28, 2) == [0, 1234]
    assert regs.read_input(38, 2) == [0xFFFF, 0xFFFF]


def test_frnet_outputs_are_one_state_seen_as_holding_input_and_coils() -> None:
    vc, regs = fresh()
    regs.write_holding(2, [0x8001])
    assert regs.read_coils(32, 16) == [True] + [False] * 14 + [True]
    regs.write_coils(33, [True])
    assert regs.read_input(2, 1) == [0x8003] and vc.frnet[2] == 0x8003
    assert refusal(regs.write_coils, 128, [True]).code == ILLEGAL_ADDRESS  # servo state: R


def test_frnet_inputs_come_from_the_simulator_extension_registers() -> None:
    vc, regs = fresh()
    regs.write_holding(9008, [0x0005])  # group 8 = discrete inputs 0..15
    assert regs.read_discrete(0, 4) == [True, False, True, False]
    assert regs.read_input(8, 1) == [5] and vc.frnet[8] == 5


def test_identity_registers_are_the_profile_values() -> None:
    _vc, regs = fresh()
    assert regs.read_input(81, 5) == [0x44, 0x0100, 0x0000, 0x0221, 0x0201]


@given(st.integers(0, 511), st.integers(-2_000_000_000, 2_000_000_000), st.sampled_from([0, 1]))
def test_any_var_round_trips_through_its_holding_pair(n: int, value: int, order: int) -> None:
    """Any value WRITE_VAR takes (RS 2394); beyond it the write is refused, see
    tests/m8194h/test_device_values.py."""
    vc, regs = fresh()
    regs.write_holding(14, [order])
    unsigned = value & 0xFFFFFFFF
    pair = [unsigned >> 16, unsigned & 0xFFFF]
    regs.write_holding(300 + 2 * n, pair if order == 0 else pair[::-1])
    assert vc.vars[n] == value
    assert regs.read_holding(300 + 2 * n, 2) == (pair if order == 0 else pair[::-1])


def test_axis_status_tables_follow_the_motion_model() -> None:
    """Registers 16-23, 58-61, 70 and discrete inputs 128-287 show the axis reports; an
    emergency stop raises the EMERGENCY bits of every axis (tables 3, 25, 26)."""
    vc, regs = fresh()
    regs.write_holding(8000, rtc("FIXED_MOVE", 2, 50000))
    vc.advance(0.05)
    y_status = regs.read_input(17, 1)[0]
    assert y_status & 1 and regs.read_discrete(144, 1) == [True]  # Y DRIVING
    assert regs.read_input(58, 4) == [1, 0, 1, 1]
    regs.write_holding(8000, rtc("EMERGENCY_STOP", 0))
    vc.advance(0.06)
    assert regs.read_input(58, 4) == [1, 1, 1, 1]
    assert regs.read_input(25, 1) == [1] and regs.read_input(70, 1) == [1]
    reports = [vc.motion.axis_report(i, vc.clock) for i in range(4)]
    assert regs.read_input(20, 4) == [r.error_code for r in reports]
    causes = regs.read_discrete(192, 64)
    assert [causes[16 * i + 5] for i in range(4)] == [True] * 4  # EMERGENCY, table 26
    signals = regs.read_discrete(256, 32)
    assert signals[24:32] == [bool((reports[3].di_signal >> n) & 1) for n in range(8)]
    assert regs.read_coils(128, 4) == [r.servo_on for r in reports]


def test_call_register_keeps_the_called_mp_while_an_isr_runs_above_it() -> None:
    vc, regs = fresh()
    download(regs, "MP 21\n TIMER 1000\nEND MP\nISR 3\n VAR1 = 1\n VAR2 = 2\n VAR3 = 3\n"
                   "END ISR\n")
    regs.write_holding(8, [21])
    vc.advance(0.01)
    vc.request_isr(3)
    vc.advance(vc.clock + 0.00015)  # the ISR has run one of its three lines
    assert regs.read_input(24, 1) == [3]  # input 24: the program running now
    assert regs.read_holding(8, 1) == [21]  # holding 8: the MP that was called
