"""The simulated machine as configuration (issue 14 item 3): a `[machine]` file puts switches,
power-on positions, encoder offsets and inputs over time into the virtual M8194H, and `mpc
run` (the client here, as a user runs it) sees them. Named after the manual sections whose
inputs they drive (RS manual: 3.5 limits, 4.2 positions, 4.6 DI status, 5 FRnet, 6 home
search, 7.5.10 emergency)."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from mplang.cli import EXIT_OK, main
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.machine import load_machine
from mplang.m8194h.run import run_build

PROFILE = """    SET_MAX_V {axes}, 80000
    SET_SV {axes}, 1000
    SET_V {axes}, 20000
    SET_A {axes}, 200000
"""


def run_json(tmp_path: Path, source: str, machine: str, *args: str) -> dict[str, object]:
    """`mpc run --json --machine M FILE` on `source` and `machine` (TOML text)."""
    program = tmp_path / "prog.mp"
    program.write_text(source)
    machine_file = tmp_path / "machine.toml"
    machine_file.write_text(machine)
    result = CliRunner().invoke(main, ["run", "--json", "--machine", str(machine_file),
                                       str(program), *args])
    assert result.exit_code == EXIT_OK, result.output
    summary: dict[str, object] = json.loads(result.stdout)
    assert summary["machine"] == str(machine_file)
    return summary


def lp(summary: dict[str, object], axis: str) -> int:
    axes = summary["axes"]
    assert isinstance(axes, dict)
    return int(axes[axis]["lp"])


def ep(summary: dict[str, object], axis: str) -> int:
    axes = summary["axes"]
    assert isinstance(axes, dict)
    return int(axes[axis]["ep"])


def var(summary: dict[str, object], name: str) -> int:
    values = summary["vars"]
    assert isinstance(values, dict)
    return int(values.get(name, 0))


def test_3_5_a_continuous_move_stops_on_the_configured_limit_switch(tmp_path: Path) -> None:
    source = ("MP 100 run_out\n" + PROFILE.format(axes="XY") +
              "    CONTINUE_MOVE X, 20000\n    CONTINUE_MOVE Y, -20000\n    STOP_WAIT X\n"
              "    STOP_WAIT Y\n"
              "    VAR1 = GET_ERROR_CODE(X)\n    VAR2 = GET_ERROR_CODE(Y)\nEND MP\n")
    machine = ("[machine.X]\nlimit-plus = 12345\n"
               "[machine.Y]\nlimit-minus = -777\nstart = 100\n")
    summary = run_json(tmp_path, source, machine)
    # a sudden stop on the switch ends exactly where it engages (LIMITSTOP_MODE 0)
    assert lp(summary, "X") == 12345 and var(summary, "VAR1") == 4  # LIMIT+
    assert lp(summary, "Y") == -877 and var(summary, "VAR2") == 8  # LIMIT-, from 100


def test_6_home_search_finds_home_at_the_configured_position(tmp_path: Path) -> None:
    """Steps 1, 2 and 4 in the negative direction (std:home_switch.mp's pattern): NHOME at
    -30000..-20000, HOME -26000..-25000; the search ends on HOME's upper edge, 1000 back."""
    source = ("MP 100 home\n" + PROFILE.format(axes="X") +
              "    SET_HV X, 2000\n    SET_HOME_MODE X, 2, 2, 0, 1, 1000\n    HOME_START X\n"
              "    STOP_WAIT X\n    VAR1 = GET_ERROR_CODE(X)\n    FIXED_MOVE X, -50000\n"
              "    STOP_WAIT X\nEND MP\n")
    machine = ("[machine.X]\nnear-home = [-30000, -20000]\nhome = [-26000, -25000]\n"
               "limit-minus = -40000\nstart = 8000\n")
    summary = run_json(tmp_path, source, machine)
    assert var(summary, "VAR1") == 0
    # LP 0 is the parked point, machine position -25000 + 1000 = -24000; the move down runs
    # into LIMIT- at machine -40000, that is LP -16000
    assert lp(summary, "X") == -16000


def test_6_home_search_finds_the_configured_index_pulse(tmp_path: Path) -> None:
    """Step 3 alone (std:home_index.mp's pattern) on a rotary axis: the next Z pulse at
    2500 + k * 10000 from the start at 4000 is 12500."""
    source = ("MP 100 index\n" + PROFILE.format(axes="U") +
              "    SET_HV U, 2000\n    SET_HOME_MODE U, 0, 0, 1, 0, 0\n    HOME_START U\n"
              "    STOP_WAIT U\n    VAR1 = GET_ERROR_CODE(U)\n    ABS_FIXED_MOVE U, -12500\n"
              "    STOP_WAIT U\n    VAR2 = GET_EP(U)\nEND MP\n")
    machine = ("[machine.U]\nnear-home = false\nhome = false\n"
               "index = { period = 10000, at = 2500 }\nstart = 4000\n")
    summary = run_json(tmp_path, source, machine)
    assert var(summary, "VAR1") == 0
    assert lp(summary, "U") == -12500  # back at machine 0: the Z pulse was at 12500


def test_6_the_default_machine_gives_home_index_the_home_error(tmp_path: Path) -> None:
    """Without a machine file the axis stands on HOME and on a Z pulse at power on: the HOME
    error (128, RS 3678), as docs/stdlib.md says of the home_index example without one."""
    build = compile_source("MP 100 index\n" + PROFILE.format(axes="U") +
                           "    SET_HOME_MODE U, 0, 0, 1, 0, 0\n    HOME_START U\n"
                           "    STOP_WAIT U\n    VAR1 = GET_ERROR_CODE(U)\nEND MP\n")
    assert run_build(build).controller.vars[1] == 128


def test_5_1_an_frnet_input_scripted_at_a_time_changes_an_if_branch(tmp_path: Path) -> None:
    source = ("MP 100 branch\n    TIMER {ms}\n    IF FRNET_READ(8, 3) == 1\n        VAR1 = 11\n"
              "    ELSE\n        VAR1 = 22\n    END IF\n    VAR2 = FRNET_IN(9)\nEND MP\n")
    machine = '[machine]\nevents = ["at 2.0 s DI8.3 = 1", "at 1500 ms DI9 = 0x00A5"]\n'
    before = run_json(tmp_path, source.format(ms=1900), machine)
    after = run_json(tmp_path, source.format(ms=2100), machine)
    assert var(before, "VAR1") == 22 and var(after, "VAR1") == 11
    assert var(before, "VAR2") == var(after, "VAR2") == 0xA5


def test_5_3_frnet_wait_ends_when_the_scripted_input_comes(tmp_path: Path) -> None:
    source = "MP 100 wait\n    FRNET_WAIT 8, 0, 1, 0\n    VAR1 = 1\nEND MP\n"
    summary = run_json(tmp_path, source, '[machine]\nevents = ["at 2.5 s DI8.0 = 1"]\n')
    assert var(summary, "VAR1") == 1
    assert 2500 <= float(str(summary["time_ms"])) < 2501


def test_4_6_when_conditions_drive_inputs_at_a_machine_position(tmp_path: Path) -> None:
    """`when X >= 5000 DI8.2 = 1`: a cam at machine position 5000 (the program sees it at
    LP 5000 - start); its reverse turns it off again, so it follows the carriage."""
    source = ("MP 100 cam\n" + PROFILE.format(axes="X") +
              "    CONTINUE_MOVE X, 20000\n    FRNET_WAIT 8, 2, 1, 0\n    VAR1 = GET_LP(X)\n"
              "    VAR2 = GET_DI(X, 7)\n    STOP_SUDDENLY X\n    STOP_WAIT X\n"
              "    ABS_FIXED_MOVE X, 0\n    STOP_WAIT X\n    VAR3 = FRNET_READ(8, 2)\n"
              "    VAR4 = GET_DI(X, 7)\nEND MP\n")
    machine = ('[machine]\nevents = ["when X >= 5000 DI8.2 = 1, X.IN3 = 1",\n'
               '          "when X < 5000 DI8.2 = 0, X.IN3 = 0"]\n[machine.X]\nstart = 2000\n')
    summary = run_json(tmp_path, source, machine)
    assert 3000 <= var(summary, "VAR1") <= 3003  # one macro line after the edge at LP 3000
    assert var(summary, "VAR2") == 0  # IN3 on: the status bit is low active (4.6.2)
    assert var(summary, "VAR3") == 0 and var(summary, "VAR4") == 1


def test_4_2_the_encoder_offset_is_ep_minus_lp(tmp_path: Path) -> None:
    source = ("MP 100 move\n" + PROFILE.format(axes="Y") + "    FIXED_MOVE Y, 1000\n"
              "    STOP_WAIT Y\n    VAR1 = GET_EP(Y)\nEND MP\n")
    summary = run_json(tmp_path, source, "[machine.Y]\nencoder-offset = -250\n")
    assert lp(summary, "Y") == 1000 and ep(summary, "Y") == 750 and var(summary, "VAR1") == 750


def test_7_5_10_the_emg_input_stops_all_axes(tmp_path: Path) -> None:
    source = ("MP 100 emg\n" + PROFILE.format(axes="XYZU") +
              "    FIXED_MOVE X, 100000\n    FIXED_MOVE Y, -100000\n"
              "    CONTINUE_MOVE Z, 10000\n"
              "    STOP_WAIT X\n    STOP_WAIT Y\n    STOP_WAIT Z\n"
              "    VAR1 = GET_ERROR_CODE(X)\n    VAR2 = GET_ERROR_CODE(U)\n"
              "    FIXED_MOVE U, 500\n    STOP_WAIT U\nEND MP\n")
    summary = run_json(tmp_path, source, '[machine]\nevents = ["at 1 s EMG = 1"]\n')
    # at 1 s all three run at full speed (the ramps end at 0.095 s): stopped at once
    assert 15000 < lp(summary, "X") < 20000 and -20000 < lp(summary, "Y") < -15000
    assert 5000 < lp(summary, "Z") < 10000
    assert var(summary, "VAR1") == var(summary, "VAR2") == 32  # EMERGENCY on every axis
    assert lp(summary, "U") == 0  # a new move is refused while EMG is asserted


def test_3_12_an_alarm_stops_its_axis_when_enabled(tmp_path: Path) -> None:
    source = ("MP 100 alarm\n" + PROFILE.format(axes="XY") + "    SET_ALARM X, 1, 0\n"
              "    FIXED_MOVE XY, 100000\n    STOP_WAIT X\n    STOP_WAIT Y\n"
              "    VAR1 = GET_ERROR_CODE(X)\n    VAR2 = GET_DI_SIGNAL(Y, 7)\nEND MP\n")
    machine = ('[machine]\nevents = ["at 1 s X.ALARM = 1, Y.ALARM = 1"]\n')
    summary = run_json(tmp_path, source, machine)
    assert lp(summary, "X") < 25000 and var(summary, "VAR1") == 16
    assert lp(summary, "Y") == 100000 and var(summary, "VAR2") == 1  # not enabled on Y


def test_3_13_inpos_follows_the_machine_file(tmp_path: Path) -> None:
    source = ("MP 100 inpos\n    VAR1 = GET_DI_SIGNAL(X, 6)\n    VAR2 = GET_DI_SIGNAL(Y, 6)\n"
              "END MP\n")
    summary = run_json(tmp_path, source, "[machine.X]\ninpos = true\n")
    assert var(summary, "VAR1") == 1  # forced on; Y: the servo is off, so no INPOS
    assert var(summary, "VAR2") == 0


def test_a_machine_file_read_as_the_library_reads_it(tmp_path: Path) -> None:
    """`load_machine` (what `mpc dap` and the face's `load_machine` call) keeps the values."""
    path = tmp_path / "m.toml"
    path.write_text('[machine]\nemg = true\nevents = ["at 250 ms X.IN3 = 1", '
                    '"when Y <= -5 DI15.15 = 1"]\n[machine.Z]\nlimit-plus = 9\n'
                    'index = false\nencoder-offset = 3\n')
    setup = load_machine(path)
    assert setup.emg and setup.axes[2].sensors.limit_plus == 9
    assert setup.axes[2].sensors.index_period is None and setup.axes[2].encoder_offset == 3
    assert setup.timed[0].time == 0.25 and setup.timed[0].changes[0].axis == 0
    watch = setup.watches[0]
    assert (watch.axis, watch.threshold, watch.above) == (1, -4, False)
    assert watch.changes[0].group == 15 and watch.changes[0].mask == 0x8000


def test_7_5_reset_card_keeps_the_machine_and_where_the_axes_stand(tmp_path: Path) -> None:
    """RESET_CARD restarts the motion chip (LP = EP = 0) but not the machine: the switches
    stay, and each axis stays where it stood on them."""
    path = tmp_path / "machine.toml"
    path.write_text("[machine.X]\nstart = 1000\nlimit-plus = 10000\n")
    build = compile_source("MP 100 out\n" + PROFILE.format(axes="X") +
                           "    FIXED_MOVE X, 5000\n    STOP_WAIT X\nEND MP\n"
                           "MP 101 again\n" + PROFILE.format(axes="X") +
                           "    FIXED_MOVE X, 8000\n    STOP_WAIT X\nEND MP\n")
    report = run_build(build, "out", machine=load_machine(path))
    vc = report.controller
    vc.reset()
    vc.advance(vc.clock + 0.01)  # the initial table loads again
    assert vc.motion.io.machine_position(0, vc.clock) == 6000
    vc.call(101)
    assert vc.run().finished
    assert vc.motion.lp(1, vc.clock) == 4000  # stopped on LIMIT+ at machine 10000
    assert vc.motion.io.error_code(1, vc.clock) == 4
