"""Changes to a running drive on the virtual M8194H: 7.1.10 SET_PULSE (change the target
position on the fly, RS 5469-5537) and 9.13 CHANGE_VEL_ON_FLY (RS 11005-11049), over real
Modbus TCP as the manual's examples send them, and as macro lines; and the commands still not
modelled, which warn when they run (`mpc run`, `mpc sim -v`) and docs/simulator.md lists."""

from __future__ import annotations

import asyncio
import math
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import AsyncModbusTcpClient
from simproc import start_sim

from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_tcp, stop
from mplang.m8194h.run import run_build
from mplang.m8194h.sim import unmodelled
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.preload import preload
from mplang.m8194h.sim.profiles import _Plan, _retarget

CAT = catalogue.load()
XYZU, X = 0xF, 0x1


def rtc(name: str, axis: int, value: int) -> list[int]:
    """The real-time frame of `name` (axis and one value) as the manual's tables print it."""
    command = next(c for c in CAT.commands if c.short_name == name and "rtc" in c.scope)
    assert command.code is not None
    if command.registers == 3:
        return [command.code, axis, value & 0xFFFF]
    return [command.code, axis, (value >> 16) & 0xFFFF, value & 0xFFFF]


def long_of(words: list[int]) -> int:
    value = (words[0] << 16) | words[1]
    return value - (1 << 32) if value >= 1 << 31 else value


SET_PULSE_EXAMPLE = [  # RS 5521-5537, in its order
    rtc("SET_MAX_V", XYZU, 20000), rtc("NORMAL_SPEED", XYZU, 0), rtc("SET_V", XYZU, 2000),
    rtc("SET_A", XYZU, 1000), rtc("SET_SV", XYZU, 2000), rtc("SET_AO", XYZU, 9),
    rtc("FIXED_MOVE", XYZU, 10000), rtc("SET_PULSE", XYZU, 9000),
]


def test_7_1_10_the_manuals_set_pulse_example_ends_at_9000_over_tcp() -> None:
    async def scenario() -> list[int]:
        face = DeviceFace(VirtualController(), SimClock(50.0))
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        try:
            assert await client.connect()
            for frame in SET_PULSE_EXAMPLE:
                assert not (await client.write_registers(8000, frame)).isError(), frame
            for _ in range(500):  # poll the stop status (input 58-61) until all four stop
                stopped = await client.read_input_registers(58, count=4)
                if stopped.registers == [1, 1, 1, 1]:
                    break
                await asyncio.sleep(0.01)
            lp = await client.read_input_registers(26, count=8)
            return [long_of(lp.registers[k:k + 2]) for k in range(0, 8, 2)]
        finally:
            client.close()
            await stop(server)

    assert asyncio.run(scenario()) == [9000, 9000, 9000, 9000]  # not 10000


def example_controller(frames: list[list[int]]) -> VirtualController:
    vc = VirtualController()
    for frame in frames:
        assert vc.write_subfunction(frame) == 0
    vc.advance(0.002)  # the FIFO runs them, 100 us each
    return vc


def test_7_1_10_set_pulse_ends_the_constant_speed_example_half_a_second_earlier() -> None:
    vc = example_controller(SET_PULSE_EXAMPLE)
    end = vc.motion.idle_at(XYZU, vc.clock)
    moved_at = 0.0007  # FIXED_MOVE is the 7th command of the FIFO
    assert end == pytest.approx(moved_at + 9000 / 2000)


def test_7_1_10_macro_set_pulse_in_a_program_ends_at_9000() -> None:
    build = compile_source("""MP 41
  SET_MAX_V XYZU, 20000
  NORMAL_SPEED XYZU, 0
  SET_V XYZU, 2000
  SET_A XYZU, 1000
  SET_SV XYZU, 2000
  SET_AO XYZU, 9
  FIXED_MOVE XYZU, 10000
  SET_PULSE XYZU, 9000
END MP
""")
    report = run_build(build)
    assert report.result.finished
    assert report.controller.snapshot()["axes"] == {
        name: {"lp": 9000, "ep": 9000} for name in ("X", "Y", "Z", "U")}


@pytest.mark.parametrize(("move", "total", "end"), [
    (10000, 4000, 4000),      # shortened during the acceleration of a T-curve
    (10000, 25000, 25000),    # lengthened
    (-10000, 4000, -4000),    # the direction stays the move's (RS 5477)
])
def test_7_1_10_set_pulse_on_a_t_curve_lands_exactly_on_the_new_total(
        move: int, total: int, end: int) -> None:
    vc = example_controller([rtc("SET_SV", X, 500), rtc("SET_V", X, 8000),
                             rtc("SET_A", X, 20000), rtc("FIXED_MOVE", X, move)])
    vc.advance(vc.clock + 0.1)  # still accelerating: 500 + 20000 * 0.1 < 8000
    speed_before = vc.motion.cv(X, vc.clock)
    vc.write_subfunction(rtc("SET_PULSE", X, total))
    vc.advance(vc.clock + 0.0002)
    assert vc.motion.cv(X, vc.clock) == pytest.approx(speed_before, rel=0.05)  # no jump
    vc.advance(vc.clock + 30.0)
    assert vc.motion.lp(X, vc.clock) == end and not vc.motion.busy(X, vc.clock)


def test_7_1_10_a_total_already_passed_stops_where_the_axis_is() -> None:
    vc = example_controller([rtc("SET_V", X, 10000), rtc("FIXED_MOVE", X, 100000)])
    vc.advance(vc.clock + 1.0)
    here = vc.motion.lp(X, vc.clock)
    vc.write_subfunction(rtc("SET_PULSE", X, 100))
    vc.advance(vc.clock + 0.001)
    assert not vc.motion.busy(X, vc.clock)
    assert here < vc.motion.lp(X, vc.clock) < here + 20  # 100 us of the command at 10000 pps
    vc.write_subfunction(rtc("SET_PULSE", X, 5000))  # idle now: logged, nothing moves
    vc.advance(vc.clock + 0.001)
    assert any("SET_PULSE 5000: no effect, X is not moving" in line for line in vc.log)


def test_9_13_change_vel_on_fly_example_accelerates_a_programs_drive_to_120000() -> None:
    """RS 11036: RSM_CHANGE_VEL_ON_FLY(hRsm, 1, AXIS_X, 120000L) while an MP drives X."""
    build = compile_source("MP 1\n  SET_V X, 10000\n  CONTINUE_MOVE X, 10000\n"
                           "  LABEL top\n  GOTO top\nEND MP\n")
    vc = VirtualController()
    preload(vc, build)
    vc.call(1)
    vc.advance(0.5)
    assert vc.motion.cv(X, vc.clock) == pytest.approx(10000)

    async def scenario() -> tuple[int, int]:
        face = DeviceFace(vc, SimClock(1.0, origin_sim=vc.clock))
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        try:
            assert await client.connect()
            frame = rtc("CHANGE_VEL_ON_FLY", X, 120000)
            assert frame == [0x0A43, 0x0001, 0x0001, 0xD4C0]  # the manual's table, RS 11044
            assert not (await client.write_registers(8000, frame)).isError()
            face.clock = SimClock(100.0, origin_sim=vc.clock)  # let the ramp pass quickly
            loop = asyncio.get_running_loop()
            end = loop.time() + 30  # polled, however long a loaded machine takes
            while True:
                cv = await client.read_input_registers(42, count=2)  # current speed X (12.1.4)
                if long_of(cv.registers) == 120000 or loop.time() > end:
                    break
                await asyncio.sleep(0.01)
            running = await client.read_input_registers(101, count=1)
            return long_of(cv.registers), running.registers[0]
        finally:
            client.close()
            await stop(server)

    speed, state = asyncio.run(scenario())
    assert speed == 120000 and state == 8  # the program still runs
    assert vc.motion.settings[0].v == 10000  # the setting is not changed


def test_9_13_change_vel_on_fly_on_a_fixed_move_still_ends_on_its_target() -> None:
    vc = example_controller([rtc("SET_V", X, 10000), rtc("FIXED_MOVE", X, 100000)])
    plain = vc.motion.idle_at(X, vc.clock)
    assert plain is not None
    vc.advance(vc.clock + 1.0)
    vc.write_subfunction(rtc("CHANGE_VEL_ON_FLY", X, 20000))
    vc.advance(vc.clock + 0.5)
    assert vc.motion.cv(X, vc.clock) == pytest.approx(20000)
    faster = vc.motion.idle_at(X, vc.clock)
    assert faster is not None and faster < plain - 3.0
    vc.advance(faster)
    assert vc.motion.lp(X, vc.clock) == 100000


# ------------------------------------------------- what is still not modelled warns
DOCS = Path(__file__).resolve().parents[3] / "docs" / "simulator.md"


def test_7_3_9_an_unmodelled_macro_line_warns_at_its_source_line_once(tmp_path: Path) -> None:
    source = tmp_path / "out.mp"
    source.write_text("MP 1\n  VAR1 = 1\n  FOR 3\n    SET_OUT X, 1, 3\n  NEXT\nEND MP\n")
    result = subprocess.run([sys.executable, "-m", "mplang", "run", str(source)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stderr.count("warning[R301]: SET_OUT is not modelled") == 1  # once, not 3
    assert f"{source}:4:5: warning[R301]: SET_OUT is not modelled by the virtual controller: " \
           "it ran with no effect (MP1 line 2)" in result.stderr


def test_7_4_13_an_unmodelled_real_time_command_is_logged_by_mpc_sim_v() -> None:
    proc, port = start_sim("-v")

    async def send() -> None:
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await client.connect()
        try:
            line_scan = [0x0A91, X, 0, 0, 1000]  # axis, Type 0, Position 1000 (7.4.13)
            assert not (await client.write_registers(8000, line_scan)).isError()
            for _ in range(5):  # each request runs the device up to the present
                await client.read_input_registers(71, count=1)
                await asyncio.sleep(0.01)
        finally:
            client.close()

    try:
        asyncio.run(send())
    finally:
        proc.send_signal(signal.SIGTERM)
        out, _err = proc.communicate(timeout=30)
    assert proc.returncode == 0
    assert "warning: LINE_SCAN_START is not modelled by the virtual controller: accepted " \
           "with no effect (real-time command)" in out


def test_simulator_docs_list_exactly_the_commands_that_warn() -> None:
    text = DOCS.read_text(encoding="utf-8")
    match = re.search(r"<!-- unmodelled -->(.*?)<!-- /unmodelled -->", text, re.S)
    assert match is not None
    listed = sorted(re.findall(r"`([A-Z_0-9]+)`", match.group(1)))
    assert listed == unmodelled.warned(VirtualController())


@settings(max_examples=300, deadline=None)
@given(sv=st.integers(100, 5000), extra=st.integers(0, 50000), frac=st.floats(0.0, 1.0),
       s0=st.integers(0, 100000), rest=st.integers(1, 200000), offset=st.integers(0, 20),
       s_curve=st.booleans(), rates=st.tuples(st.integers(1000, 10**6), st.integers(1000, 10**6)))
def test_7_1_10_a_replanned_drive_ends_exactly_on_its_total_without_speeding(
        sv: int, extra: int, frac: float, s0: int, rest: int, offset: int, s_curve: bool,
        rates: tuple[int, int]) -> None:
    """From any present speed between SV and V: the path length rises to the new total and
    stops there, the speed stays between 0 and the larger of the present and the new V."""
    v = sv + extra
    v0 = sv + frac * (v - sv)
    plan = _Plan(float(sv), float(v), float(rates[0]), float(rates[1]), s_curve,
                 offset=float(offset))
    prof = _retarget(float(s0), v0, float(s0 + rest), plan)
    assert prof.duration < math.inf
    assert prof.state(prof.duration)[0] == s0 + rest
    last = float(s0)
    for k in range(1, 41):
        s, speed, _a = prof.state(prof.duration * k / 40)
        assert s >= last - 1e-6 and -1e-6 <= speed <= max(v0, v) * (1 + 1e-9) + 1e-6
        last = s
    pieces_end = prof.segs[-1] if prof.segs else None
    if pieces_end is not None:  # the pieces themselves reach the total: no jump at the end
        p, speed, acc, jerk = pieces_end
        dt = prof.duration - prof.starts[-1]
        reached = p + speed * dt + acc * dt * dt / 2 + jerk * dt ** 3 / 6
        assert reached == pytest.approx(s0 + rest, abs=1e-3 * max(1.0, rest))
