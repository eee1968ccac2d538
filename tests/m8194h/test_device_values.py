"""The virtual M8194H holds the values the device holds and answers as it answers (issue 24).

Raw clients only: bytes over loopback TCP and over a pty pair (RTU) where the frame is the
point, pymodbus's client elsewhere; no mplang client code. RS = RS-M8194H manual line.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import struct
from collections.abc import AsyncIterator, Awaitable, Callable

import pytest
from pymodbus.framer import FramerRTU
from test_device_refusals import CLOSE, CREATE, ILLEGAL_FUNCTION, Device, macro, on, rtc
from test_modbus import frames, until

from mplang.family.ptylink import PtyLink
from mplang.ir.macro import VarRef
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

ILLEGAL_ADDRESS, ILLEGAL_VALUE, BUSY = 0x02, 0x03, 0x06
X, Y = 1, 2
Ask = Callable[[bytes], Awaitable[bytes]]


# ----------------------------------------------------------------- raw frames, both ways
@contextlib.asynccontextmanager
async def raw(transport: str, face: DeviceFace | None = None) -> AsyncIterator[Ask]:
    """A function that sends one request PDU to a served controller (unit 1) and returns the
    answer's PDU, framed by hand: MBAP over TCP, address + CRC over RTU."""
    face = face or DeviceFace(VirtualController(), SimClock(1.0))
    if transport == "tcp":
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        tid = 0

        async def ask_tcp(pdu: bytes) -> bytes:
            nonlocal tid
            tid += 1
            writer.write(struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu)
            await writer.drain()
            header = await asyncio.wait_for(reader.readexactly(7), 2)
            assert struct.unpack(">H", header[:2])[0] == tid
            return await reader.readexactly(struct.unpack(">H", header[4:6])[0] - 1)
        try:
            yield ask_tcp
        finally:
            writer.close()
            await stop(server)
        return
    import tty  # POSIX only, as the pty itself
    with PtyLink() as link:
        rtu_server = await serve_rtu(face, link.device_end, unit=1)
        fd = os.open(link.client_end, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(fd)

        async def ask_rtu(pdu: bytes) -> bytes:
            body = bytes([1]) + pdu
            os.write(fd, body + _crc(body))
            got = b""
            loop = asyncio.get_running_loop()
            end = loop.time() + 2
            while len(got) < 5 or _crc(got[:-2]) != got[-2:]:
                assert loop.time() < end, f"no answer to {pdu.hex()} (got {got.hex()})"
                with contextlib.suppress(BlockingIOError):
                    got += os.read(fd, 256)
                await asyncio.sleep(0.005)
            assert got[0] == 1
            return got[1:-2]
        try:
            yield ask_rtu
        finally:
            os.close(fd)
            await stop(rtu_server)


def _crc(data: bytes) -> bytes:
    """The RTU CRC as it goes on the line (pymodbus's, not mplang's)."""
    return FramerRTU.compute_CRC(data).to_bytes(2, "big")


def over(transport: str, scenario: Callable[[Ask, DeviceFace], Awaitable[None]]) -> None:
    async def main() -> None:
        face = DeviceFace(VirtualController(), SimClock(1.0))
        async with raw(transport, face) as ask:
            await scenario(ask, face)
    asyncio.run(main())


TRANSPORTS = pytest.mark.parametrize("transport", ["tcp", "rtu"])


def exception(fc: int, code: int) -> bytes:
    return bytes([fc | 0x80, code])


# -------------------------------------------- item 3: exception frames and quantity limits
@TRANSPORTS
def test_a_bad_quantity_is_the_requests_code_plus_0x80_with_exception_3(transport: str) -> None:
    """FC3/FC4 of 0 or 126 registers, FC1/FC2 of 0 or 2001 bits, FC15 of 1969 bits, FC16 of
    124 registers or with a byte count that does not match: function code + 0x80 and
    MB_ILLEGAL_DATA_VALUE 3 (Table 3, RS 939); the limits themselves are served."""
    async def scenario(ask: Ask, face: DeviceFace) -> None:
        for fc, count in ((3, 126), (3, 0), (4, 0), (4, 126), (2, 0), (2, 2001), (1, 2001),
                          (1, 0)):
            assert await ask(struct.pack(">BHH", fc, 0, count)) == exception(fc, 3), (fc, count)
        coils = (1969 + 7) // 8
        assert await ask(struct.pack(">BHHB", 15, 0, 1969, coils) + bytes(coils)) == \
            exception(15, 3)
        assert await ask(struct.pack(">BHHB", 15, 0, 0, 0)) == exception(15, 3)
        assert await ask(struct.pack(">BHHB", 16, 300, 124, 248) + bytes(248)) == \
            exception(16, 3)
        assert await ask(struct.pack(">BHHBH", 16, 300, 2, 2, 5)) == exception(16, 3)
        assert (await ask(struct.pack(">BHH", 3, 128, 125)))[:2] == bytes([3, 250])
        assert (await ask(struct.pack(">BHH", 4, 0, 125)))[:2] == bytes([4, 250])
        assert (await ask(struct.pack(">BHH", 1, 0, 132)))[:2] == bytes([1, 17])
        assert all(r.code == 3 for r in face.refusals)
        assert face.controller.illegal_cause == 0  # register 102 is ILLEGAL FUNCTION's
    over(transport, scenario)


@TRANSPORTS
def test_an_unsupported_function_code_still_answers_exception_1(transport: str) -> None:
    async def scenario(ask: Ask, face: DeviceFace) -> None:
        assert await ask(bytes([0x17, 0, 0, 0, 1, 0, 0, 0, 1, 2, 0, 0])) == exception(0x17, 1)
        assert face.controller.illegal_cause == 1
    over(transport, scenario)


# ---------------------------------------------------------------- item 6: FC5's values
@TRANSPORTS
def test_fc5_with_a_value_other_than_on_or_off_is_exception_3(transport: str) -> None:
    """Modbus FC5 takes 0xFF00 (ON) or 0x0000 (OFF); 0x1234 is refused and the coil stays;
    a valid write is echoed."""
    async def scenario(ask: Ask, face: DeviceFace) -> None:
        assert await ask(struct.pack(">BHH", 5, 3, 0x1234)) == exception(5, 3)
        assert await ask(struct.pack(">BHH", 5, 3, 0x0001)) == exception(5, 3)
        assert face.controller.frnet[0] == 0
        assert await ask(struct.pack(">BHH", 5, 3, 0xFF00)) == struct.pack(">BHH", 5, 3, 0xFF00)
        assert face.controller.frnet[0] == 0x0008
        assert await ask(struct.pack(">BHH", 5, 3, 0x0000)) == struct.pack(">BHH", 5, 3, 0)
        assert face.controller.frnet[0] == 0
    over(transport, scenario)


# ------------------------------------------------------- item 7: reserved holding registers
@TRANSPORTS
def test_reserved_holding_registers_are_exception_2(transport: str) -> None:
    """10-13 are 'Reserved ... Not defined' (RS 11444), 15-81, 122-127 and 256-299 are in no
    table: a read or write starting there is exception 2; 8-14 read in one request (the
    reserved words as 0), as `mpc monitor` reads them."""
    async def scenario(ask: Ask, _face: DeviceFace) -> None:
        for address in (10, 13, 20, 30, 81, 122, 256, 299):
            assert await ask(struct.pack(">BHH", 3, address, 1)) == exception(3, 2), address
            assert await ask(struct.pack(">BHH", 6, address, 1)) == exception(6, 2), address
        assert await ask(struct.pack(">BHHBH", 16, 12, 1, 2, 0)) == exception(16, 2)
        assert await ask(struct.pack(">BHH", 3, 8, 7)) == bytes([3, 14]) + bytes(14)
        assert await ask(struct.pack(">BHH", 6, 14, 1)) == struct.pack(">BHH", 6, 14, 1)
        assert await ask(struct.pack(">BHH", 3, 8, 7)) == bytes([3, 14]) + bytes(12) + b"\0\1"
    over(transport, scenario)


# -------------------------------------------- item 4: one range for a variable, every route
@TRANSPORTS
def test_bvar_and_var_register_writes_out_of_range_are_refused_like_the_subfunction(
        transport: str) -> None:
    """bVAR 300 through holding 128 + n is exception 3 (Table 3: invalid data ... VAR bVAR,
    RS 939) and stores nothing, as WRITE_bVAR 300 is refused (cause 2); a VAR pair beyond
    +-2,000,000,000 (WRITE_VAR's range, RS 2394) likewise; an FC16 with one bad value writes
    none of its values."""
    async def scenario(ask: Ask, face: DeviceFace) -> None:
        vc = face.controller
        assert await ask(struct.pack(">BHH", 6, 128 + 5, 300)) == exception(6, 3)
        assert await ask(struct.pack(">BHHBHH", 16, 128, 2, 4, 7, 256)) == exception(16, 3)
        assert vc.bvars[:6] == [0] * 6
        assert await ask(struct.pack(">BHH", 6, 128 + 5, 255)) == struct.pack(">BHH", 6, 133, 255)
        assert vc.bvars[5] == 255
        big = 2_000_000_001
        assert await ask(struct.pack(">BHHBHH", 16, 300, 2, 4, big >> 16, big & 0xFFFF)) == \
            exception(16, 3)
        low = -2_000_000_001 & 0xFFFFFFFF
        assert await ask(struct.pack(">BHHBHH", 16, 302, 2, 4, low >> 16, low & 0xFFFF)) == \
            exception(16, 3)
        ok = 2_000_000_000
        assert await ask(struct.pack(">BHHBHH", 16, 300, 2, 4, ok >> 16, ok & 0xFFFF)) == \
            struct.pack(">BHH", 16, 300, 2)
        assert vc.vars[:2] == [ok, 0]
        frame = [0x0A23, 0x80 + 1, 300]  # RSM_WRITE_bVAR bVAR1, 300 (appendix table 21)
        body = struct.pack(f">BHHB{len(frame)}H", 16, 8000, len(frame), 2 * len(frame), *frame)
        assert await ask(body) == exception(16, ILLEGAL_FUNCTION)
        assert vc.illegal_cause == 0x02 and vc.bvars[1] == 0
    over(transport, scenario)


# ------------------------------------------------- item 5: MP_CALL while a program runs
MP_TIMER = "MP 7 waits\n TIMER 5000\nEND MP\nMP 8 other\n VAR1 = 1\nEND MP\n"


def test_rtc_mp_call_while_a_program_runs_is_refused_as_holding_8_is() -> None:
    """Holding 8 refuses a call while MP7 runs with cause 0xC3 (RS 11370); the MP_CALL
    sub-function gets the same answer on arrival instead of an OK that never runs, and MP8
    does not run when MP7 ends."""
    async def scenario(device: Device) -> None:
        for frame in frames(MP_TIMER):
            assert await device.write(frame) == 0
        assert not (await device.client.write_register(8, 7, device_id=1)).isError()
        await until(lambda: _running(device, 7))
        reply = await device.client.write_register(8, 8, device_id=1)
        assert reply.isError() and reply.exception_code == ILLEGAL_FUNCTION
        assert await device.cause() == 0xC3
        assert await device.write(rtc("MP_CALL", 8)) == ILLEGAL_FUNCTION
        assert await device.cause() == 0xC3
        assert (await device.inputs(71))[0] == 30  # nothing waits in the FIFO
        assert device.vc.vars[1] == 0
    on("tcp", scenario, speed=1.0)


async def _running(device: Device, slot: int) -> bool:
    return (await device.inputs(24))[0] == slot


def test_rtc_mp_call_when_nothing_runs_is_acknowledged_and_runs() -> None:
    async def scenario(device: Device) -> None:
        for frame in frames(MP_TIMER):
            assert await device.write(frame) == 0
        assert await device.write(rtc("MP_CALL", 8)) == 0

        async def done() -> bool:
            reply = await device.client.read_holding_registers(302, count=2, device_id=1)
            return list(reply.registers) == [0, 1]
        await until(done)
    on("tcp", scenario)


# ------------------------------------------------------------ item 7: input registers 110-111
def test_a_download_names_its_own_kind_and_zeroes_the_other() -> None:
    """Profile `download.status_numbers` = last-download: 110/111 tell the host which kind
    the last download was (RS 10961, 10972): ISR2 then MP3 reads 3, 0; then ISR4 reads 0, 4."""
    async def scenario(device: Device) -> None:
        for source, expected in (("ISR 2\n VAR1 = 1\nEND ISR\n", [0, 2]),
                                 ("MP 3\n VAR1 = 1\nEND MP\n", [3, 0]),
                                 ("ISR 4\n VAR1 = 1\nEND ISR\n", [0, 4])):
            for frame in frames(source):
                assert await device.write(frame) == 0
            assert (await device.status())[:2] == expected
    on("tcp", scenario)


# --------------------------------------------- item 7: the FIFO's 30 entries at wall clock
def test_a_host_sending_back_to_back_fills_the_fifo_at_wall_clock_speed() -> None:
    """A served controller drains one real-time command per
    `execution.served_rtc_command_time_us` (5 ms): 60 SET_V frames from four clients, each
    sent as soon as the last was answered, meet exception 6 once 30 wait (RS 324, 942), and
    the device catches up afterwards."""
    async def scenario(ask: Ask, face: DeviceFace) -> None:
        frame = rtc("SET_V", X, 1000)
        body = struct.pack(f">BHHB{len(frame)}H", 16, 8000, len(frame), 2 * len(frame), *frame)
        answers = await burst(face, body, 4, 15)
        accepted = [a for a in answers if a[0] == 16]
        busy = [a for a in answers if a == exception(16, BUSY)]
        assert len(accepted) + len(busy) == 60
        assert len(accepted) >= 30 and busy
        assert face.controller.rtc_time == pytest.approx(0.005)

        async def drained() -> bool:
            reply = await ask(struct.pack(">BHH", 4, 71, 1))
            return reply == bytes([4, 2, 0, 30])
        await until(drained)
    over("tcp", scenario)


async def burst(face: DeviceFace, pdu: bytes, connections: int, each: int) -> list[bytes]:
    """Send a request `each` times on each of `connections` TCP connections at once (the
    ET-M8194H serves several clients, input register 86), each one as soon as the last
    answer came; return every answer."""
    server, port = await serve_tcp(face, "127.0.0.1", 0)

    async def client() -> list[bytes]:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        answers = []
        try:
            for n in range(1, each + 1):
                writer.write(struct.pack(">HHHB", n, 0, len(pdu) + 1, 1) + pdu)
                await writer.drain()
                header = await asyncio.wait_for(reader.readexactly(7), 5)
                answers.append(await reader.readexactly(struct.unpack(">H", header[4:6])[0] - 1))
            return answers
        finally:
            writer.close()
    try:
        return [a for got in await asyncio.gather(*(client() for _ in range(connections)))
                for a in got]
    finally:
        await stop(server)


# ------------------------------------------ items 1 and 2: speeds above MAX_V, CV register
def _cv(words: list[int]) -> int:
    return (words[0] << 16) | words[1]


def test_a_speed_above_max_v_runs_at_max_v_and_cv_shows_it() -> None:
    """SET_MAX_V X 8000 then SET_V X 12000: X cruises at 8000 PPS, what CV (input 42) reads;
    CHANGE_VEL_ON_FLY Y 300000 with MAX_V 200000 reaches 200000, not 300000 (RS 1146)."""
    async def scenario(device: Device) -> None:
        for frame in (rtc("SET_MAX_V", X, 8000), rtc("SET_V", X, 12000),
                      rtc("CONTINUE_MOVE", X, 12000), rtc("SET_A", Y, 8_000_000),
                      rtc("SET_V", Y, 10000), rtc("CONTINUE_MOVE", Y, 10000)):
            assert await device.write(frame) == 0
        await asyncio.sleep(0.3)  # X's ramp takes 70 ms, Y's 1.1 ms
        assert _cv(await device.inputs(42, 2)) == 8000
        assert _cv(await device.inputs(44, 2)) == 10000
        assert await device.write(rtc("CHANGE_VEL_ON_FLY", Y, 300000)) == 0
        await asyncio.sleep(0.2)  # 190,000 PPS at 8,000,000 PPS/s: 24 ms
        assert _cv(await device.inputs(44, 2)) == 200000
        reply = await device.client.read_holding_registers(106, count=4, device_id=1)
        assert [_cv(reply.registers[0:2]), _cv(reply.registers[2:4])] == [8000, 200000]
        assert await device.write(rtc("STOP_SUDDENLY", X | Y)) == 0
    on("tcp", scenario)


def test_speed_and_acceleration_macro_lines_run_with_the_chip_values() -> None:
    """The same values from a macro program: MAX_V 8000, V 12000 cruises at 8000."""
    async def scenario(device: Device) -> None:
        source = ("MP 9\n SET_MAX_V X, 8000\n SET_V X, 12000\n CONTINUE_MOVE X, 12000\n"
                  "END MP\n")
        for frame in frames(source):
            assert await device.write(frame) == 0
        assert await device.write(rtc("MP_CALL", 9)) == 0
        await asyncio.sleep(0.3)
        assert _cv(await device.inputs(42, 2)) == 8000
        assert await device.write(macro("STOP_SUDDENLY", X)) != 0  # a macro code as RTC
        assert await device.write(rtc("STOP_SUDDENLY", X)) == 0
    on("tcp", scenario)


def test_every_route_to_a_var_refuses_the_same_value() -> None:
    """2,000,000,001 is beyond WRITE_VAR's range (RS 2394): the sub-function (cause 2), the
    holding pair (exception 3) and a SET_VAR macro line in a download (cause 2, the
    download fails) all refuse it; 2,000,000,000 passes every route."""
    async def scenario(device: Device) -> None:
        await device.refused(rtc("WRITE_VAR", VarRef(3), 2_000_000_001), 0x02)
        reply = await device.client.write_registers(306, [0x7735, 0x9401], device_id=1)
        assert reply.isError() and reply.exception_code == ILLEGAL_VALUE
        assert device.vc.vars[3] == 0
        assert await device.write([CREATE, 5]) == 0
        await device.refused(macro("SET_VAR", VarRef(3), 2_000_000_001), 0x02)
        assert await device.write(macro("SET_VAR", VarRef(3), 2_000_000_000)) == 0
        assert await device.write([CLOSE]) == 0
        assert ("mp", 5) not in device.vc.tables
        reply = await device.client.write_registers(306, [0x7735, 0x9400], device_id=1)
        assert not reply.isError() and device.vc.vars[3] == 2_000_000_000
    on("tcp", scenario)
