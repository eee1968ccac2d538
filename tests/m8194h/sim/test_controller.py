"""The virtual controller: chapter 9 semantics, its own download validation, persistence.

Expectations are computed from the manual's statements, not from its prose: the 9.4 example
says VAR1 = 10, VAR2 = 200, VAR3 = 2000, but its statements give VAR1 = 0, VAR2 = 2000,
VAR3 = 200.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.encode import Encoder
from mplang.m8194h.run import run_build
from mplang.m8194h.sim.controller import VirtualController

CAT = catalogue.load()
ENC = Encoder(CAT)


def run(source: str, call: str | None = None) -> VirtualController:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    report = run_build(build, call)
    assert report.result.finished, report.result.error
    return report.controller


def variables(controller: VirtualController, *indexes: int) -> list[int]:
    return [controller.vars[i] for i in indexes]


def test_manual_9_4_arithmetic_as_its_statements_compute() -> None:
    vc = run("""MP 100
  VAR1 = 100
  VAR2 = 200
  VAR10 = 10
  VAR6 = FRNET_IN(8)
  VAR5 = GET_LP(X)
  VAR3 = VAR1 + VAR2
  VAR3 = VAR3 - VAR1
  VAR2 = VAR3 * VAR10
  VAR1 = VAR3 / VAR2
END MP
""")
    assert variables(vc, 1, 2, 3, 10, 5, 6) == [0, 2000, 200, 10, 0, 0]


def test_for_counts_its_variable_down_to_zero() -> None:
    vc = run("MP 1\n VAR1 = 5\n VAR2 = 0\n FOR VAR1\n  VAR2 = VAR2 + 1\n NEXT\nEND MP\n")
    assert variables(vc, 1, 2) == [0, 5]


def test_nested_for_with_constant_counts_and_exit_for() -> None:
    vc = run("""MP 41
  VAR1 = 0
  FOR 3
    FOR 4
      VAR1 = VAR1 + 1
      IF VAR1 == 10
        EXIT FOR
      END IF
    NEXT
  NEXT
END MP
""")
    assert vc.vars[1] == 10  # 4 + 4, then the third pass leaves its inner loop at 10


def test_if_else_and_goto_loop() -> None:
    vc = run("""MP 41
  VAR1 = 0
  VAR2 = 0
  LABEL top
  VAR1 = VAR1 + 1
  IF VAR1 < 7
    GOTO top
  ELSE
    VAR2 = 1
  END IF
END MP
""")
    assert variables(vc, 1, 2) == [7, 1]


def test_call_exit_returns_one_level_and_terminate_stops_all() -> None:
    vc = run("""MP 1 main
  VAR1 = 1
  CALL sub
  VAR1 = VAR1 + 100
END MP
MP 2 sub
  VAR1 = VAR1 + 10
  EXIT
  VAR1 = 999
END MP
""")
    assert vc.vars[1] == 111
    vc = run("MP 1 main\n VAR1 = 1\n CALL sub\n VAR1 = 5\nEND MP\n"
             "MP 2 sub\n TERMINATE\nEND MP\n")
    assert vc.vars[1] == 1


def test_call_depth_and_empty_slot_are_execution_errors() -> None:
    chain = "".join(f"MP {n}\n CALL MP{n + 1}\nEND MP\n" for n in range(1, 9)) + \
        "MP 9\n EXIT\nEND MP\n"
    build = compile_source(chain)  # the compiler reports E433 ...
    assert "E433" in {d.code for d in build.diagnostics}
    vc = VirtualController()  # ... and the device, given such tables anyway, stops at run time
    for n in range(1, 10):
        body = [[0x0CCB, n + 1]] if n < 9 else [[0x0CDD]]
        assert vc.load_frames("mp", n, [[0x0AC9, n], *body, [0x0CCA]]) is None
    vc.call(1)
    outcome = vc.run()
    assert not outcome.finished and "nested" in (outcome.error or "")
    assert vc.execution_error[4] == 0x01 and vc.execution_error[0] == 7


def test_division_by_zero_is_an_execution_error() -> None:
    build = compile_source("MP 1\n VAR1 = 0\n VAR2 = 5 / VAR1\nEND MP\n")
    outcome = run_build(build).result
    assert not outcome.finished and "division by zero" in (outcome.error or "")


def test_timer_advances_simulated_time() -> None:
    report = run_build(compile_source("MP 1\n TIMER 1500\n VAR1 = 1\nEND MP\n"))
    assert report.result.finished and 1.5 <= report.result.time_s < 1.51


@pytest.mark.parametrize(("body", "error", "line"), [
    ([[0x0CD6]], 0x09, 0),                                     # NEXT outside FOR
    ([[0x0CD5, 0, 3]], 0x0A, 0),                               # FOR not closed
    ([[0x0CD8]], 0x03, 0),                                     # ELSE outside IF
    ([[0x0CD9]], 0x04, 0),                                     # END_IF outside IF
    ([[0x0CD7, 0, 1, 0x3D3C, 0, 2]], 0x05, 0),                 # IF not closed
    ([[0x0CD7, 0, 1, 0x1234, 0, 2], [0x0CD9]], 0x06, 0),       # wrong IF operator
    ([[0x0CDE]], 0x08, 0),                                     # EXIT_FOR outside FOR
    ([[0x0CE1, 1], [0x0CE1, 1]], 0x0B, 1),                     # label twice
    ([[0x0CD7, 0, 1, 0x3C, 0, 2], [0x0CE1, 0], [0x0CD9]], 0x0C, 1),  # LABEL inside IF
    ([[0x0CD5, 0, 2], [0x0CE1, 0], [0x0CD6]], 0x0D, 1),        # LABEL inside FOR
    ([[0x0CDF, 2]], 0x0E, 0),                                  # GOTO without LABEL
    ([[0x0CD4, 0, 1, 0x25, 0, 2, 0x7FFF, 1]], 0x10, 0),        # '%' is no operator
])
def test_device_rejects_bad_tables_itself(body: list[list[int]], error: int, line: int) -> None:
    vc = VirtualController()
    result = vc.load_frames("mp", 41, [[0x0AC9, 41], *body, [0x0CCA]])
    assert result is not None and (result.code, result.line) == (error, line)
    assert ("mp", 41) not in vc.tables and vc.state == "ready"
    assert vc.download_status[0] == 41 and vc.download_status[4] == error


def test_nesting_limits_and_budget_on_the_device() -> None:
    vc = VirtualController()
    deep_if = [[0x0CD7, 0, 1, 0x3C, 0, 2]] * 8 + [[0x0CD9]] * 8
    result = vc.load_frames("mp", 151, [[0x0AC9, 151], *deep_if, [0x0CCA]])
    assert result is not None and result.code == 0x02
    vc = VirtualController()
    assert vc.write_subfunction([0x0AC9, 1]) == 0
    for _ in range(8):
        vc.write_subfunction([0x0CDD])
    assert vc.write_subfunction([0x0CDD]) == 0x04  # the ninth line does not fit an 8-line slot
    vc.write_subfunction([0x0CCA])  # 8 lines + close: too long with the close counted
    assert vc.download_status[4] == 0x01


def test_illegal_function_causes() -> None:
    vc = VirtualController()
    assert vc.write_subfunction([0x0C4E, 1, 0, 5]) == 0x08   # macro command as RTC
    assert vc.write_subfunction([0x0ACD, 3]) == 0            # ISR download
    assert vc.write_subfunction([0x0CD5, 0, 3]) == 0x05      # FOR is MP-only
    assert vc.write_subfunction([0x0A0A]) == 0x07            # RTC inside a download
    assert vc.write_subfunction([0x0ABC]) == 0x02            # INTP_END needs 2 registers
    assert vc.write_subfunction([0x0CCE]) == 0 and vc.state == "ready"


def test_if_operator_in_the_manuals_printed_byte_order_is_accepted() -> None:
    vc = VirtualController()
    frames = [[0x0AC9, 1], [0x0CD2, 0x7FFF, 1, 0, 1], [0x0CD7, 0x7FFF, 1, 0x3C3D, 0, 1],
              [0x0CD2, 0x7FFF, 2, 0, 9], [0x0CD9], [0x0CCA]]
    assert vc.load_frames("mp", 1, frames) is None
    vc.call(1)
    assert vc.run().finished and vc.vars[2] == 9


def test_macro_memory_persists(tmp_path: Path) -> None:
    build = compile_source("MP 21\n VAR1 = 42\nEND MP\n")
    first = run_build(build).controller
    store = tmp_path / "fram.json"
    first.save(store)
    second = VirtualController()
    second.restore(store)
    second.call(21)
    assert second.run().finished and second.vars[1] == 42


def test_isr_call_preempts_the_running_program_which_then_resumes() -> None:
    build = compile_source("MP 21\n VAR1 = 1\n TIMER 1000\n VAR3 = VAR2 + VAR1\nEND MP\n"
                           "ISR 3\n VAR2 = 40\n VAR1 = VAR1 + 1\nEND ISR\n")
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController()
    for program in build.programs:
        assert vc.load_frames(program.program.kind, program.placement.slot,
                              program.frames) is None
    vc.call(21)
    vc.advance(0.5)
    assert vc.chip_state == 8 and vc.vars[1] == 1
    isr_call = CAT.by_vendor["RSM_MP_ISR_CALL"].code
    assert vc.write_subfunction([isr_call, 3]) == 0
    vc.advance(0.502)
    assert vc.vars[1:3] == [2, 40] and vc.chip_state == 8  # ISR done, MP21 still waits
    vc.advance(2.0)
    assert vc.vars[3] == 42 and vc.chip_state == 9 and not vc.running
    assert vc.write_subfunction([isr_call, 5]) == 0  # an empty ISR: the request is dropped
    vc.advance(2.1)
    assert not vc.running and any("ISR5 is empty" in entry for entry in vc.log)


def test_interrupt_after_the_program_ended_still_runs_its_isr() -> None:
    """D-END of a move the program left running raises ISR2 after MP21 has finished:
    `mpc run` waits for the motion, so the ISR runs too."""
    vc = run("MP 21\n INTFACTOR_ENABLE X, 7, 2\n ENABLE_INT\n FIXED_MOVE X, 1000\nEND MP\n"
             "ISR 2\n VAR5 = GET_LP(X)\nEND ISR\n")
    assert vc.vars[5] == 1000 and vc.chip_state == 11


def test_rsm_write_md_is_carried_out_as_it_arrives() -> None:
    """The manual's RSM_WRITE_MD frames (RS 2623-2651) take effect with the write, before any
    simulated time passes: MD100 = 0x12345678 and MD1500 = 321.65, and nothing is queued."""
    vc = VirtualController()
    assert vc.write_subfunction([0x0A27, 0x0000, 0x0064, 0x1234, 0x5678, 0x0000, 0x0000]) == 0
    assert vc.write_subfunction([0x0A27, 0x0000, 0x05DC, 0x0000, 0x0000, 0x43A0, 0xD333]) == 0
    assert vc.md.word(100) == 0x12345678 and vc.md.word(1500) == 0x43A0D333
    assert not vc.fifo
