"""The bounded queues of the virtual M8194H: the command FIFO (4.10, RS 3729; input register
71 'The maximum block is 30', 12.1.7 RS 11308) and the motion queue of commands waiting for
their axes (profile `limits.motion_queue`, see device-choices.md). A program that outruns the
axes waits; `mpc run` and `mpc sim` stay proportional to the time simulated."""

from __future__ import annotations

import asyncio
import re
import signal
import subprocess
import sys
from pathlib import Path

from pymodbus.client import AsyncModbusTcpClient
from simproc import start_sim

from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim.controller import DeviceBusy, VirtualController
from mplang.m8194h.sim.preload import preload

CAPACITY = catalogue.load().profile.limit("motion_queue")
FIXED_MOVE, DRV_HOLD, DRV_START = 0x0A4E, 0x0AB4, 0x0AB5  # real-time codes (7.1.9, 7.5.1-2)

OUTRUN = """MP 1
  LABEL top
  FIXED_MOVE X, 100
  GOTO top
END MP
"""


def loaded(source: str) -> VirtualController:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController()
    preload(vc, build)
    return vc


def move_x(pulses: int) -> list[int]:
    return [FIXED_MOVE, 1, (pulses >> 16) & 0xFFFF, pulses & 0xFFFF]


def test_12_1_7_motion_queue_of_a_program_that_outruns_the_axes_stays_bounded() -> None:
    vc = loaded(OUTRUN)
    vc.call(1)
    steps = []
    for until in (1.0, 5.0, 20.0):
        steps.append(vc.advance(until))
        assert vc.motion.waiting_commands() == CAPACITY  # full, never more
        assert vc.running and vc.error is None  # the program waits; it does not fail
    # every move is made, back to back: LP advanced by 100 per started move; each issued
    # move took FIXED_MOVE and GOTO (which jumps past LABEL), and each one issued once the
    # queue was full also one refused FIXED_MOVE before it: no busy polling
    issued = vc.motion.lp(1, vc.clock) // 100 + 1 + CAPACITY
    assert abs(sum(steps) - (2 * issued + issued - CAPACITY - 1)) <= 3
    # 15 s of outrunning costs 15/4 the lines of the 4 s before it: proportional to time
    assert 3.4 <= steps[2] / steps[1] <= 4.1


def test_12_1_7_a_full_queue_of_held_commands_waits_for_ever_on_the_line() -> None:
    """DRV_HOLD (7.5.1): held commands wait for DRV_START; the 31st waits on its line."""
    vc = loaded("MP 1\n  DRV_HOLD X\n  LABEL top\n  FIXED_MOVE X, 100\n  GOTO top\nEND MP\n")
    vc.call(1)
    result = vc.run(max_time=2.0)
    assert not result.finished and result.error is not None
    assert "FIXED_MOVE at line 2 of MP1 waits for ever" in result.error
    assert vc.motion.waiting_commands() == CAPACITY
    vc.write_subfunction([DRV_START, 1])  # released from the host: it runs on
    vc.advance(vc.clock + 1.0)
    assert vc.motion.lp(1, vc.clock) > 0 and vc.motion.waiting_commands() <= CAPACITY


def test_4_10_real_time_moves_fill_the_motion_queue_then_the_fifo_answers_busy() -> None:
    """RS 324, 942: a full FIFO answers exception 0x06; the motion queue behind it stays
    bounded, and the FIFO's head waits for room instead of being lost."""
    vc = VirtualController()
    busy = sent = 0
    for _ in range(400):
        try:
            vc.write_subfunction(move_x(100))
            sent += 1
        except DeviceBusy:
            busy += 1
        vc.advance(vc.clock + 0.0005)
        assert vc.motion.waiting_commands() <= CAPACITY
        assert len(vc.fifo) <= vc.fifo_capacity
    assert busy > 0
    vc.advance(vc.clock + 60.0)  # everything accepted is moved, nothing is dropped
    assert vc.motion.lp(1, vc.clock) == 100 * sent


def test_7_5_1_held_real_time_moves_beyond_the_queue_are_dropped_not_blocking() -> None:
    vc = VirtualController()
    vc.write_subfunction([DRV_HOLD, 1])
    vc.advance(0.001)
    for _ in range(CAPACITY + 5):
        vc.write_subfunction(move_x(100))
        vc.advance(vc.clock + 0.0002)
    assert vc.motion.waiting_commands() == CAPACITY
    assert any("dropped: the motion queue is full" in line for line in vc.log)
    vc.write_subfunction([DRV_START, 1])  # not stuck behind a dropped command
    vc.advance(vc.clock + 10.0)
    assert vc.motion.lp(1, vc.clock) == 100 * CAPACITY


def test_7_4_3_continuous_segments_ahead_of_the_axes_are_bounded_and_keep_running() -> None:
    vc = loaded("""MP 41
  LINE_2D_INITIAL X, Y, 300, 18000, 500000
  LABEL top
  LINE_2D_CONTINUE 0, 100, 100
  GOTO top
END MP
""")
    vc.call(41)
    for until in (1.0, 3.0):
        vc.advance(until)
        chain = vc.motion._open
        assert chain is not None and chain.started
        ahead = len(chain.path.offsets) - sum(1 for o in chain.path.offsets
                                              if o <= chain.motion.prof.state(
                                                  until - chain.motion.t0)[0])
        assert ahead <= CAPACITY
    assert vc.motion.cv(1, vc.clock) > 12_000  # still at full speed: never ran out


def mpc(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=120, cwd=cwd)


def test_12_1_7_mpc_run_of_the_outrunning_program_ends_at_max_time(tmp_path: Path) -> None:
    (tmp_path / "outrun.mp").write_text(OUTRUN)
    lines = []
    for max_time in ("5", "20"):
        result = mpc("run", "outrun.mp", "--max-time", max_time, cwd=tmp_path)
        assert result.returncode == 18, result.stderr  # out of --max-time: 18 since issue 14 item 4
        head = re.search(r"MP1: FAILED after ([\d.]+) ms simulated, (\d+) lines", result.stdout)
        assert head is not None, result.stdout
        assert float(head.group(1)) == float(max_time) * 1000
        lines.append(int(head.group(2)))
        assert "without finishing" in result.stderr and "Traceback" not in result.stderr
    assert 3.4 <= lines[1] / lines[0] <= 4.3  # the work is proportional to --max-time


COUNTING = """MP 1
  LABEL top
  FIXED_MOVE X, 100
  VAR1 = VAR1 + 1
  GOTO top
END MP
"""


def test_12_1_7_mpc_sim_serving_the_outrunning_program_answers_and_ends_on_sigterm(
        tmp_path: Path) -> None:
    """Over Modbus TCP: call MP1 at holding register 8 (12.2.2), then read VAR1 (moves
    issued, holding 302) and LP X (input 26): their difference is the queue, which stays
    within the profile's bound while the program runs 20 times faster than the clock."""
    (tmp_path / "counting.mp").write_text(COUNTING)
    proc, port = start_sim(str(tmp_path / "counting.mp"), "--speed", "20")

    async def client() -> list[int]:
        modbus = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await modbus.connect()
        try:
            await modbus.write_register(8, 1)
            queued = []
            for _ in range(20):
                await asyncio.sleep(0.1)
                var1 = await modbus.read_holding_registers(302, count=2)
                lp = await modbus.read_input_registers(26, count=2)
                assert not var1.isError() and not lp.isError()
                issued = (var1.registers[0] << 16) | var1.registers[1]
                done = ((lp.registers[0] << 16) | lp.registers[1]) // 100
                queued.append(issued - done)
            return queued
        finally:
            modbus.close()

    try:
        queued = asyncio.run(client())
        # VAR1 is read before LP, so moves that end between the two reads only lower it
        assert max(queued) <= CAPACITY + 1  # the waiting commands and the running one
        assert max(queued[-5:]) >= CAPACITY // 2  # ... and the program did outrun the axes
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(30) == 0
