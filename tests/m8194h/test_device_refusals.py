"""The virtual M8194H refuses what the device refuses, whoever sends it (issue 13 items 1, 2, 7).

Every test is a raw Modbus client (pymodbus, no mplang client code) talking to a served virtual
controller over loopback TCP, and the main ones over a pty pair (RTU) too. Named after the
manual section each checks (RS = RS-M8194H manual line).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Awaitable, Callable

import pytest
from deviceframes import CLOSE, CREATE, CREATE_ISR, ISR_CLOSE, macro, rtc, variant
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from simproc import start_sim

from mplang.family.ptylink import PtyLink
from mplang.ir.macro import VarRef
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

ILLEGAL_FUNCTION, DEVICE_FAILURE = 0x01, 0x04
Client = AsyncModbusTcpClient | AsyncModbusSerialClient


class Device:
    """A raw Modbus client to one served virtual controller."""

    def __init__(self, client: Client, face: DeviceFace) -> None:
        self.client, self.face, self.vc = client, face, face.controller

    async def write(self, frame: list[int]) -> int:
        """Write a frame at 8000; the Modbus exception code, or 0 when acknowledged."""
        reply = await self.client.write_registers(8000, frame, device_id=1)
        return int(reply.exception_code) if reply.isError() else 0

    async def inputs(self, address: int, count: int = 1) -> list[int]:
        reply = await self.client.read_input_registers(address, count=count, device_id=1)
        assert not reply.isError(), reply
        return list(reply.registers)

    async def cause(self) -> int:
        return (await self.inputs(102))[0]

    async def status(self) -> list[int]:
        return await self.inputs(110, 5)

    async def refused(self, frame: list[int], cause: int) -> None:
        """The frame is answered ILLEGAL FUNCTION with register 102 = cause."""
        assert await self.write(frame) == ILLEGAL_FUNCTION, frame
        assert await self.cause() == cause, frame


@contextlib.asynccontextmanager
async def served(transport: str, speed: float = 1.0) -> AsyncIterator[Device]:
    face = DeviceFace(VirtualController(), SimClock(speed))
    if transport == "tcp":
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client: Client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=2, retries=0)
        try:
            assert await client.connect()
            yield Device(client, face)
        finally:
            client.close()
            await stop(server)
        return
    with PtyLink() as link:
        rtu_server = await serve_rtu(face, link.device_end, unit=1)
        serial = AsyncModbusSerialClient(link.client_end, baudrate=115200, timeout=2, retries=0)
        try:
            assert await serial.connect()
            yield Device(serial, face)
        finally:
            serial.close()
            await stop(rtu_server)


def on(transport: str, scenario: Callable[[Device], Awaitable[None]], speed: float = 1.0) -> None:
    async def main() -> None:
        async with served(transport, speed) as device:
            await scenario(device)
    asyncio.run(main())


TRANSPORTS = pytest.mark.parametrize("transport", ["tcp", "rtu"])


# ------------------------------------------------------------ 12.1.12 cause 2 in real time
@TRANSPORTS
def test_12_1_12_cause_2_out_of_range_real_time_commands_are_refused_and_not_run(
        transport: str) -> None:
    """SET_V on axis 0x20, FIXED_MOVE of 2.1e9, MP_CALL 200 / 0, WRITE_VAR VAR600 (VARs are
    VAR0..VAR511, RS 2394, 10144): ILLEGAL FUNCTION, cause 2 (RS 11366-11368), nothing queued;
    the device answers on and a valid write still works."""
    async def scenario(device: Device) -> None:
        fifo_free = (await device.inputs(71))[0]
        for frame in (rtc("SET_V", 0x20, 1000), rtc("SET_V", 0, 1000),
                      rtc("FIXED_MOVE", 1, 2_100_000_000), rtc("MP_CALL", 200),
                      rtc("MP_CALL", 0), rtc("MP_ISR_CALL", 21), rtc("WRITE_VAR", VarRef(600), 5),
                      rtc("WRITE_VAR", VarRef(1), 2_000_000_001), rtc("VECTOR_SPEED", 12),
                      rtc("STOP_WAIT", 3)):
            await device.refused(frame, 0x02)
            assert (await device.inputs(71))[0] == fifo_free  # nothing queued
        assert await device.write(rtc("WRITE_VAR", VarRef(511), -7)) == 0
        await asyncio.sleep(0.05)
        reply = await device.client.read_holding_registers(300 + 2 * 511, count=2, device_id=1)
        assert reply.registers == [0xFFFF, 0xFFF9]
        assert await device.cause() == 0
    on(transport, scenario)


# ------------------------------------------------------------------ 9.12 download status
@TRANSPORTS
def test_9_12_a_refused_line_fails_the_download_and_110_to_114_name_it(transport: str) -> None:
    """MP1 (8 lines) with three ARC_CW (2 lines each), a SET_VAR and a fourth ARC_CW: the
    fourth is refused (cause 4) and the close reports download error 0x01 at its line 7 with
    its command; MP1 is not stored (RS 10961, 10974)."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 1]) == 0
        arc = macro("ARC_CW", 0, 100, 0, 200)
        for _ in range(3):
            assert await device.write(arc) == 0
        assert await device.write(macro("SET_VAR", VarRef(1), 5)) == 0
        await device.refused(arc, 0x04)
        assert (await device.inputs(100))[0] == 1  # still downloading until the close
        assert await device.write([CLOSE]) == 0
        assert await device.inputs(100) == [0]
        assert await device.status() == [1, 0, 0x0C65, 7, 0x01]
        assert ("mp", 1) not in device.vc.tables
        reply = await device.client.write_register(8, 1, device_id=1)  # call MP1: it is empty
        assert reply.isError() and await device.cause() == 0x02
    on(transport, scenario)


OUT_OF_RANGE_LINES = [
    ("axis 0", macro("FIXED_MOVE", 0, 100)),
    ("axis 0x20", macro("SET_V", 0x20, 100)),
    ("VAR512 target", macro("SET_VAR", VarRef(512), 1)),
    ("VAR600 source", macro("SET_VAR", VarRef(1), VarRef(600))),
    ("immediate target", macro("SET_VAR", 7, 1)),
    ("data over 2,000,000,000", macro("FIXED_MOVE", 1, 2_000_000_001)),
    ("TIMER -5", macro("TIMER", -5)),
    ("MP_CALL MP0", macro("MP_CALL", 0)),
    ("MP_CALL MP158", macro("MP_CALL", 158)),
    ("LABEL 5 (labels 0..3, RS 10719)", macro("LABEL", 5)),
    ("GOTO 5", macro("GOTO", 5)),
    ("VAR_CALCULATE into VAR512", macro("VAR_CALCULATE", 1, 0x2B, 2, VarRef(512))),
    ("ISR number 21", macro("INTFACTOR_ENABLE", 1, 0, 21)),
    ("enumeration", macro("NORMAL_SPEED", 1, 4)),
    ("FRnet DO group 8 (RS 4427)", macro("FRNET_WRITE", 8, 0, 1)),
]


@pytest.mark.parametrize(("what", "line"), OUT_OF_RANGE_LINES,
                         ids=[w for w, _ in OUT_OF_RANGE_LINES])
def test_12_1_12_cause_2_out_of_range_lines_fail_the_download(what: str, line: list[int]) -> None:
    """Each parameter the manual bounds, in a download: cause 2, download error 0x0F at the
    line, nothing stored (a slot that held a program is empty after the failed download)."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 41]) == 0
        assert await device.write(macro("SET_VAR", VarRef(1), 1)) == 0
        assert await device.write([CLOSE]) == 0 and await device.status() == [41, 0, 0, 0, 0]
        assert await device.write([CREATE, 41]) == 0
        assert await device.write(macro("SET_VAR", VarRef(2), 2)) == 0
        await device.refused(line, 0x02)
        assert await device.write(macro("SET_VAR", VarRef(3), 3)) == 0  # still downloading
        assert await device.write([CLOSE]) == 0
        assert await device.status() == [41, 0, line[0], 1, 0x0F]
        assert ("mp", 41) not in device.vc.tables
    on("tcp", scenario)


def test_9_2_scope_refusals_fail_the_download() -> None:
    """FOR in an ISR (RS 10012: cause 5) and MP_ISR_CLOSE inside an MP (cause 6) are refused
    and fail their downloads (0x0F); an RTC command inside a download is cause 7."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE_ISR, 3]) == 0
        await device.refused(macro("FOR", 3), 0x05)
        await device.refused(macro("NEXT"), 0x05)
        assert await device.write([ISR_CLOSE]) == 0
        assert await device.status() == [0, 3, 0x0CD5, 0, 0x0F]
        assert await device.write([CREATE, 2]) == 0
        await device.refused([ISR_CLOSE], 0x06)
        await device.refused(rtc("RESET_CARD"), 0x07)
        assert await device.write([CLOSE]) == 0
        assert await device.status() == [2, 0, ISR_CLOSE, 0, 0x0F]
        assert not device.vc.tables
    on("tcp", scenario)


def test_9_12_download_error_0x0f_undefined_macro_command() -> None:
    """An undefined command "will not be written to the FRAM" (RS 10974): cause 3 at the
    frame, download error 0x0F with its code at the close."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 2]) == 0
        assert await device.write(macro("SET_VAR", VarRef(1), 1)) == 0
        await device.refused([0x0CFF, 1, 2], 0x03)
        assert await device.write([CLOSE]) == 0
        assert await device.status() == [2, 0, 0x0CFF, 1, 0x0F]
    on("tcp", scenario)


IF = macro("IF", 1, 0x3C, 2)
FOR = macro("FOR", 2)
STRUCTURE_AT_THE_LINE = [
    ("0xB1 IF nested too deep", [IF] * 7, IF, 0xB1, 0x02),
    ("0xB2 ELSE outside IF", [], macro("ELSE"), 0xB2, 0x03),
    ("0xB3 END_IF outside IF", [], macro("END_IF"), 0xB3, 0x04),
    ("0xB5 FOR nested too deep", [FOR] * 7, FOR, 0xB5, 0x07),
    ("0xB6 EXIT_FOR outside FOR", [], macro("EXIT_FOR"), 0xB6, 0x08),
    ("0xB7 NEXT outside FOR", [], macro("NEXT"), 0xB7, 0x09),
    ("0xB9 label twice", [macro("LABEL", 1)], macro("LABEL", 1), 0xB9, 0x0B),
    ("0xBA LABEL inside IF", [IF], macro("LABEL", 0), 0xBA, 0x0C),
    ("0xBB LABEL inside FOR", [FOR], macro("LABEL", 0), 0xBB, 0x0D),
    ("wrong IF operator", [], macro("IF", 1, 0x1234, 2), 0x02, 0x06),
    ("wrong VAR_CALCULATE operator", [], macro("VAR_CALCULATE", 1, 0x25, 2, VarRef(1)), 0x02,
     0x10),
]


@pytest.mark.parametrize(("what", "before", "line", "cause", "error"), STRUCTURE_AT_THE_LINE,
                         ids=[s[0] for s in STRUCTURE_AT_THE_LINE])
def test_12_1_12_structure_causes_at_the_line(what: str, before: list[list[int]],
                                              line: list[int], cause: int, error: int) -> None:
    """The structural causes 0xB1-0xBB where the appendix assigns them (RS 11368): the line
    that breaks the structure is refused with its cause, and the download fails with the
    matching download error at that line (RS 10974)."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 151]) == 0
        for frame in before:
            assert await device.write(frame) == 0, frame
        await device.refused(line, cause)
        assert await device.write([CLOSE]) == 0
        assert await device.status() == [151, 0, line[0], len(before), error]
        assert ("mp", 151) not in device.vc.tables
    on("tcp", scenario)


STRUCTURE_AT_THE_CLOSE = [
    ("0xB4 IF not closed", [macro("SET_VAR", VarRef(1), 1), IF], 0xB4, 0x05, 1),
    ("0xB8 FOR not closed", [FOR], 0xB8, 0x0A, 0),
    ("0xBC GOTO without LABEL", [macro("GOTO", 2)], 0xBC, 0x0E, 0),
]


@pytest.mark.parametrize(("what", "lines", "cause", "error", "at"), STRUCTURE_AT_THE_CLOSE,
                         ids=[s[0] for s in STRUCTURE_AT_THE_CLOSE])
def test_12_1_12_structure_causes_at_the_close(what: str, lines: list[list[int]], cause: int,
                                               error: int, at: int) -> None:
    """What only the close can see: the close ends the download (acknowledged, device ready),
    register 102 holds the cause and 110-114 the error at the opening line."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 41]) == 0
        for frame in lines:
            assert await device.write(frame) == 0
        assert await device.write([CLOSE]) == 0
        assert await device.inputs(100) == [0] and await device.cause() == cause
        assert await device.status() == [41, 0, lines[at][0], at, error]
    on("tcp", scenario)


def test_9_12_budget_overflow_names_the_failing_line() -> None:
    """Eight one-line commands fill MP1's 8 lines; the close is the line that does not fit:
    112/113 name it (MP_CLOSE at line 8), not the line before; register 102 = 4."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 1]) == 0
        for n in range(8):
            assert await device.write(macro("SET_VAR", VarRef(n), n)) == 0
        assert await device.write([CLOSE]) == 0
        assert await device.status() == [1, 0, CLOSE, 8, 0x01]
        assert await device.cause() == 0x04
    on("tcp", scenario)


@TRANSPORTS
def test_9_1_2_mp_close_outside_a_download_is_ignored(transport: str) -> None:
    """"Otherwise, it will be ignored" (RS 9886): acknowledged, nothing changes."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 1]) == 0
        assert await device.write([CLOSE]) == 0
        before = await device.inputs(100, 20)
        assert await device.write([CLOSE]) == 0
        after = await device.inputs(100, 20)
        assert after[0] == 0 and after[2] == 0 and after[10:15] == before[10:15] == [1, 0, 0, 0, 0]
        await device.refused([ISR_CLOSE], 0x08)  # no such sentence for the ISR close
    on(transport, scenario)


# ------------------------------------------------------------------ never falls over
def test_12_1_14_a_fault_inside_a_request_is_exception_4_and_the_device_answers_on(
        caplog: pytest.LogCaptureFixture) -> None:
    """An internal fault while serving one write becomes SLAVE DEVICE FAILURE (exception 4)
    with a logged diagnostic; the device answers the next request."""
    async def scenario(device: Device) -> None:
        vc = device.vc
        original = vc.initial_table.refusal

        def broken(*_args: object) -> int:
            vc.initial_table.refusal = original  # type: ignore[method-assign]
            raise RuntimeError("injected fault")
        vc.initial_table.refusal = broken  # type: ignore[method-assign]
        assert await device.write(rtc("SET_V", 1, 100)) == DEVICE_FAILURE
        assert any("injected fault" in r.getMessage() for r in caplog.records)
        assert await device.inputs(100) == [0]
        assert await device.write(rtc("SET_V", 1, 100)) == 0
    on("tcp", scenario)


def test_12_1_14_execution_faults_land_in_115_to_119() -> None:
    """A fault while a program runs (here injected into SET_V's handler) stops the program
    with an execution error in 115-119 (command, line, type 4), never the server."""
    async def scenario(device: Device) -> None:
        vc = device.vc

        def broken(*_args: object) -> None:
            raise IndexError("injected")
        vc.handlers["SET_V"] = broken
        assert await device.write([CREATE, 21]) == 0
        assert await device.write(macro("SET_VAR", VarRef(1), 1)) == 0
        assert await device.write(macro("SET_V", 1, 100)) == 0
        assert await device.write([CLOSE]) == 0
        assert not (await device.client.write_register(8, 21, device_id=1)).isError()
        await asyncio.sleep(0.05)
        assert await device.inputs(115, 5) == [21, 0, 0x0C48, 1, 0x04]
        assert (await device.inputs(101))[0] == 9  # execution ended, the device is ready
    on("tcp", scenario)


def test_12_1_14_a_fault_while_catching_up_stops_the_programs_not_the_server(
        caplog: pytest.LogCaptureFixture) -> None:
    """A fault in the device's own time keeping (here injected into the motion model while
    MP21 waits in a TIMER) stops the programs with an execution error in 115-119 and is
    logged; the device answers on, ready for the next call."""
    async def scenario(device: Device) -> None:
        vc = device.vc
        assert await device.write([CREATE, 21]) == 0
        assert await device.write(macro("TIMER", 10_000)) == 0
        assert await device.write([CLOSE]) == 0
        assert not (await device.client.write_register(8, 21, device_id=1)).isError()
        original = vc.motion.next_interrupt

        def broken(_now: float) -> float | None:
            vc.motion.next_interrupt = original  # type: ignore[method-assign]
            raise ZeroDivisionError("injected")
        vc.motion.next_interrupt = broken  # type: ignore[method-assign]
        await asyncio.sleep(0.02)
        assert await device.inputs(115, 5) == [21, 0, 0x0CDA, 0, 0x04]
        assert (await device.inputs(101))[0] == 9 and not vc.running
        assert any("injected" in r.getMessage() for r in caplog.records)
        assert not (await device.client.write_register(8, 21, device_id=1)).isError()
    on("tcp", scenario)


def test_3_18_mpc_sim_survives_write_var_var600_and_bad_tables() -> None:
    """The issue's crash, against the `mpc sim` process: a real-time WRITE_VAR naming VAR600
    (RS 2394, 10144) and a table with a VAR512 target are refused (cause 2), and the process
    answers on and still ends cleanly on SIGTERM."""
    proc, port = start_sim("--speed", "20")

    async def scenario() -> list[int]:
        client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=2, retries=0)
        assert await client.connect()
        try:
            write = await client.write_registers(8000, rtc("WRITE_VAR", VarRef(600), 5),
                                                 device_id=1)
            assert write.isError() and write.exception_code == ILLEGAL_FUNCTION
            for frame in ([CREATE, 21], macro("SET_VAR", VarRef(512), 1), [CLOSE]):
                await client.write_registers(8000, frame, device_id=1)
            await client.write_register(8, 21, device_id=1)  # MP21 is empty: refused
            await asyncio.sleep(0.1)
            reply = await client.read_input_registers(100, count=20, device_id=1)
            assert not reply.isError()
            return list(reply.registers)
        finally:
            client.close()

    try:
        registers = asyncio.run(scenario())
        assert registers[0] == 0 and registers[10:15] == [21, 0, 0x0CD2, 0, 0x0F]
        assert registers[15:20] == [0, 0, 0, 0, 0]
        assert proc.poll() is None  # still running
    finally:
        proc.terminate()
        assert proc.wait(10) == 0


def test_9_12_the_other_download_choices_of_the_profile() -> None:
    """refused_line = "ends": the refused line ends the download at once, later lines are
    macro commands outside a download (cause 8) and the close is ignored (RS 9886);
    close_failure = "refused": a table wrong at the close is answered with its cause."""
    async def scenario(device: Device) -> None:
        assert await device.write([CREATE, 41]) == 0
        await device.refused(macro("SET_VAR", VarRef(512), 1), 0x02)
        assert await device.inputs(100) == [0] and await device.status() == [41, 0, 0x0CD2, 0,
                                                                               0x0F]
        await device.refused(macro("SET_VAR", VarRef(1), 1), 0x08)
        assert await device.write([CLOSE]) == 0
        assert await device.write([CREATE, 41]) == 0
        assert await device.write(FOR) == 0
        await device.refused([CLOSE], 0xB8)
        assert await device.inputs(100) == [0] and await device.status() == [41, 0, 0x0CD5, 0,
                                                                               0x0A]
        assert not device.vc.tables

    async def main() -> None:
        face = DeviceFace(variant(refused_line="ends", close_failure="refused"), SimClock(1.0))
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=2, retries=0)
        try:
            assert await client.connect()
            await scenario(Device(client, face))
        finally:
            client.close()
            await stop(server)
    asyncio.run(main())
    with pytest.raises(ValueError, match="refused_line = 'sometimes'"):
        vc = variant(refused_line="sometimes")
        vc.write_subfunction([CREATE, 1])
        vc.write_subfunction([0x0CFF])
