"""The virtual M8194H over real Modbus: pymodbus clients over loopback TCP and over a pty
pair (RTU), and Debian's mbpoll (libmodbus) as an independent client."""

from __future__ import annotations

import asyncio
import shutil
import socket
import struct
import subprocess
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException
from simproc import start_sim

from mplang.family.ptylink import PtyLink
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.modbus import DeviceLink, Endpoint, LinkLost, crc16
from mplang.m8194h.modbus_server import (
    DeviceFace,
    SimClock,
    rtu_frame_size,
    serve_rtu,
    serve_tcp,
    stop,
)
from mplang.m8194h.sim.controller import VirtualController

PROGRAM = """MP 21
  VAR1 = 123456
  VAR2 = -5
  SET_V X, 20000
  FIXED_MOVE X, 5000
  STOP_WAIT X
  VAR3 = GET_LP(X)
END MP
"""


def frames(source: str) -> list[list[int]]:
    build = compile_source(source)
    assert build.ok
    return [f for program in build.programs for f in program.frames]


def served(speed: float = 50.0) -> DeviceFace:
    return DeviceFace(VirtualController(), SimClock(speed))


async def until(predicate: Callable[[], Awaitable[bool]], timeout: float = 30.0) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not await predicate():
        assert loop.time() < end, "the condition never came true"
        await asyncio.sleep(0.01)


def test_rtu_crc_is_the_modbus_one_low_byte_first() -> None:
    """The Modbus over serial line guide's example: read 10 holding registers of unit 1
    carries CRC 0xCDC5, sent C5 CD; the frame finder agrees with it."""
    request = bytes.fromhex("01030000000a")
    assert crc16(request) == bytes.fromhex("c5cd")
    assert rtu_frame_size(request + crc16(request) + b"\x01") == len(request) + 2


def test_download_call_and_poll_over_tcp() -> None:
    async def scenario() -> None:
        face = served()
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        try:
            assert await client.connect()
            for frame in frames(PROGRAM):
                reply = await client.write_registers(8000, frame, device_id=1)
                assert not reply.isError(), frame
            status = await client.read_input_registers(110, count=5, device_id=1)
            assert status.registers == [21, 0, 0, 0, 0]
            assert not (await client.write_register(8, 21, device_id=1)).isError()

            async def finished() -> bool:
                state = await client.read_input_registers(101, count=1, device_id=1)
                return state.registers == [9]

            await until(finished)
            variables = await client.read_holding_registers(302, count=6, device_id=1)
            assert variables.registers == [0x0001, 0xE240, 0xFFFF, 0xFFFB, 0, 5000]
            lp = await client.read_input_registers(26, count=2, device_id=1)
            assert lp.registers == [0, 5000]
        finally:
            client.close()
            await stop(server)

    asyncio.run(scenario())


def test_device_exceptions_over_tcp() -> None:
    async def scenario() -> None:
        face = served(speed=1e-4)  # slow motion: the FIFO cannot drain during the test
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        try:
            assert await client.connect()
            reply = await client.write_registers(8000, [0x0C4E, 1, 0, 5], device_id=1)
            assert reply.isError() and reply.exception_code == 0x01
            cause = await client.read_input_registers(102, count=1, device_id=1)
            assert cause.registers == [0x08]  # a macro command sent as a real-time one
            reply = await client.read_input_registers(300, count=1, device_id=1)
            assert reply.isError() and reply.exception_code == 0x02
            for _ in range(30):
                ok = await client.write_registers(8000, [0x0A48, 1, 0, 5000], device_id=1)
                assert not ok.isError()
            busy = await client.write_registers(8000, [0x0A48, 1, 0, 5000], device_id=1)
            assert busy.isError() and busy.exception_code == 0x06
            free = await client.read_input_registers(71, count=1, device_id=1)
            assert free.registers == [0]
        finally:
            client.close()
            await stop(server)

    asyncio.run(scenario())


def test_rtu_over_a_pty_pair_and_silence_for_other_units() -> None:
    async def scenario() -> None:
        face = served()
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=3)
            client = AsyncModbusSerialClient(link.client_end, baudrate=115200, timeout=3.0,
                                             retries=0)
            try:
                assert await client.connect()
                for frame in frames(PROGRAM):
                    assert not (await client.write_registers(8000, frame, device_id=3)).isError()
                assert not (await client.write_register(8, 21, device_id=3)).isError()

                async def finished() -> bool:
                    state = await client.read_input_registers(101, count=1, device_id=3)
                    return state.registers == [9]

                await until(finished)
                reply = await client.read_holding_registers(306, count=2, device_id=3)
                assert reply.registers == [0, 5000]
                with pytest.raises(ModbusException):  # a real slave stays silent
                    await client.read_holding_registers(302, count=2, device_id=4)
            finally:
                client.close()
                await stop(server)

    asyncio.run(scenario())


MBPOLL = shutil.which("mbpoll")
needs_mbpoll = pytest.mark.needs_tool("mbpoll")  # tests/conftest.py: fails under CI=true


async def mbpoll(*args: str) -> str:
    assert MBPOLL is not None, "mbpoll is missing: `make tools` installs it with apt-get"
    proc = await asyncio.create_subprocess_exec(MBPOLL, "-1", "-0", *args,
                                                stdout=asyncio.subprocess.PIPE,
                                                stderr=asyncio.subprocess.STDOUT)
    out, _ = await asyncio.wait_for(proc.communicate(), 20)
    assert proc.returncode == 0, out.decode()
    return out.decode()


async def run_program(face: DeviceFace) -> None:
    vc = face.controller
    for frame in frames(PROGRAM):
        assert vc.write_subfunction(frame) == 0
    vc.call(21)
    vc.advance(vc.clock + 2.0)
    assert not vc.running


@needs_mbpoll
def test_mbpoll_reads_positions_and_vars_over_tcp() -> None:
    async def scenario() -> None:
        face = served()
        await run_program(face)
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            out = await mbpoll("-m", "tcp", "-p", str(port), "-a", "1", "-t", "3:int", "-B",
                               "-r", "26", "-c", "1", "127.0.0.1")
            assert "[26]: \t5000" in out
            out = await mbpoll("-m", "tcp", "-p", str(port), "-a", "1", "-t", "4:int", "-B",
                               "-r", "302", "-c", "2", "127.0.0.1")
            assert "[302]: \t123456" in out and "[304]: \t-5" in out
            out = await mbpoll("-m", "tcp", "-p", str(port), "-a", "1", "-t", "4", "-r", "14",
                               "127.0.0.1", "1")  # switch to LSW first
            out = await mbpoll("-m", "tcp", "-p", str(port), "-a", "1", "-t", "4:int",
                               "-r", "302", "-c", "1", "127.0.0.1")  # mbpoll's default order
            assert "[302]: \t123456" in out
        finally:
            await stop(server)

    asyncio.run(scenario())


@needs_mbpoll
def test_mbpoll_reads_over_rtu() -> None:
    async def scenario() -> None:
        face = served()
        await run_program(face)
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=1)
            try:
                out = await mbpoll("-m", "rtu", "-b", "115200", "-P", "none", "-a", "1",
                                   "-t", "3:int", "-B", "-r", "26", "-c", "1", link.client_end)
                assert "[26]: \t5000" in out
            finally:
                await stop(server)

    asyncio.run(scenario())


# ----------------------------------------------------------------------- mpc sim (CLI)


def test_mpc_sim_keeps_macro_memory_across_a_restart(tmp_path: Path) -> None:
    source = tmp_path / "job.mp"
    source.write_text("MP 21\n VAR1 = 42\nEND MP\n")
    memory = tmp_path / "fram.json"
    first = subprocess.run([sys.executable, "-m", "mplang", "sim", str(source), "--tcp",
                            "127.0.0.1:0", "--memory", str(memory), "--duration", "0.3"],
                           capture_output=True, text=True, timeout=120)
    assert first.returncode == 0, first.stdout + first.stderr
    assert memory.exists()
    proc, port = start_sim("--memory", str(memory), "--speed", "20")

    async def call() -> list[int]:
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await client.connect()
        try:
            assert not (await client.write_register(8, 21, device_id=1)).isError()
            seen: list[int] = []

            async def written() -> bool:  # polled: no guess at how long the call takes
                seen[:] = (await client.read_holding_registers(302, count=2,
                                                               device_id=1)).registers
                return seen == [0, 42]

            await until(written, timeout=30)
            return seen
        finally:
            client.close()

    try:
        assert asyncio.run(call()) == [0, 42]
    finally:
        proc.terminate()
        assert proc.wait(10) == 0


def test_mpc_sim_rejects_bad_setups_with_distinct_exit_codes(tmp_path: Path) -> None:
    def sim(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "mplang", "sim", *args, "--duration",
                               "0.1"], capture_output=True, text=True, timeout=120)

    usage = sim("--tcp", "localhost:http")
    assert usage.returncode == 2 and "HOST:PORT" in usage.stderr
    broken = tmp_path / "fram.json"
    broken.write_text("{not json")
    memory = sim("--memory", str(broken), "--tcp", "127.0.0.1:0")
    assert memory.returncode == 3 and "not a macro memory file" in memory.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        busy = sim("--tcp", f"127.0.0.1:{port}")
    assert busy.returncode == 6 and "cannot listen" in busy.stderr
    missing = sim("--serial", str(tmp_path / "no-such-tty"))
    assert missing.returncode == 6 and "cannot open serial port" in missing.stderr
    for result in (usage, memory, busy, missing):
        assert "Traceback" not in result.stderr + result.stdout


def test_a_device_link_over_rtu_sees_its_line_go_away() -> None:
    """The client reads and writes its port itself (`lean_serial`): a download goes through
    whole, and a line that goes away while a request waits (the pty's other side closed, as
    a USB adapter pulled out) fails that request as a lost connection at once, not as a
    device that kept quiet for the whole timeout."""

    async def scenario() -> None:
        face = served()
        line = PtyLink()
        server = await serve_rtu(face, line.device_end, unit=1)
        try:
            async with DeviceLink(Endpoint(serial=line.client_end, unit=1, timeout=30.0,
                                           retries=0)) as link:
                for frame in frames(PROGRAM):
                    await link.write_frame(frame)
                assert await link.read_input(100, 1) == [0]
            async with DeviceLink(Endpoint(serial=line.client_end, unit=2, timeout=30.0,
                                           retries=0)) as link:
                waiting = asyncio.create_task(link.read_input(100, 1))  # unit 2: no answer
                await asyncio.sleep(0.2)
                line.close()
                with pytest.raises(LinkLost):
                    await waiting
        finally:
            await stop(server)
        assert [list(x.frame) for x in face.controller.tables[("mp", 21)].lines] == \
            frames(PROGRAM)[1:-1]

    asyncio.run(scenario())


FROZEN_PROBE = """
import asyncio, gc, sys
if sys.argv[1] == "mpc":
    import mplang.cli  # what an mpc process has loaded
from mplang.m8194h.modbus_server import DeviceFace, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

async def main() -> None:
    face = DeviceFace(VirtualController())
    walked = [any(o is face.controller for o in gc.get_objects())]
    server, _port = await serve_tcp(face, "127.0.0.1", 0)
    walked.append(any(o is face.controller for o in gc.get_objects()))
    await stop(server)
    print(*walked)

asyncio.run(main())
"""


@pytest.mark.parametrize(("process", "after"), [("mpc", "False"), ("library", "True")])
def test_an_mpc_process_serving_freezes_its_start_up_heap(process: str, after: str) -> None:
    """In `mpc sim` the first server to start takes the controllers made at start-up out of
    the cyclic collector's walks; a library user's objects stay collectable."""
    done = subprocess.run([sys.executable, "-c", FROZEN_PROBE, process], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", after]


class Recorder(asyncio.Protocol):
    """A Modbus TCP device that keeps every request's bytes and answers an FC16 with its
    first 12 bytes (length 6), a read of n registers with 0x0101 * k for register k, whole
    or, when `pieces`, in two reads."""

    def __init__(self, pieces: bool) -> None:
        self.pieces = pieces
        self.requests: list[bytes] = []

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        self.requests.append(data)
        answer = data[:4] + b"\x00\x06" + data[6:12]
        if data[7] in (3, 4):
            count = int.from_bytes(data[10:12], "big")
            answer = data[:4] + struct.pack(f">HBBB{count}H", 3 + 2 * count, data[6], data[7],
                                            2 * count, *(0x0101 * k for k in range(count)))
        write = self.transport.write  # type: ignore[attr-defined]
        if self.pieces:
            write(answer[:5])
            asyncio.get_running_loop().call_later(0.01, write, answer[5:])
        else:
            write(answer)


@pytest.mark.parametrize("pieces", [False, True])
def test_a_links_fc16_bytes_are_pymodbuss(pieces: bool) -> None:
    """DeviceLink packs an FC16 itself: its bytes are those pymodbus's PDU and framer make,
    and its answer, and a read's, is taken whole (the awaited header and length) or cut in
    pieces (pymodbus's framer)."""
    from pymodbus.framer import FramerSocket
    from pymodbus.pdu import DecodePDU
    from pymodbus.pdu.register_message import (
        ReadHoldingRegistersRequest,
        ReadInputRegistersRequest,
        WriteMultipleRegistersRequest,
    )

    writes = [(8000, [0x0CD2, 0x7FFF, 2, 0, 5]), (8, [0]), (14, [1]), (3000, [0xFFFF] * 123)]

    async def main() -> list[bytes]:
        recorder = Recorder(pieces)
        server = await asyncio.get_running_loop().create_server(lambda: recorder, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        try:
            async with DeviceLink(Endpoint(host="127.0.0.1", port=port, unit=3)) as link:
                await link.write_frame(writes[0][1])
                await link.write_once(*writes[1])
                await link.write_holding(*writes[2])
                await link.write_holding(*writes[3])
                assert await link.read_input(100, 15) == [0x0101 * k for k in range(15)]
                assert await link.read_holding(14, 1) == [0]
                assert link.settled and link.anomalies == 0
        finally:
            server.close()
        return recorder.requests

    framer = FramerSocket(DecodePDU(False))
    expected = []
    for tid, (address, values) in enumerate(writes, start=1):
        request = WriteMultipleRegistersRequest(address=address, registers=values, dev_id=3,
                                                transaction_id=tid)
        expected.append(framer.buildFrame(request))
    reads = [ReadInputRegistersRequest(address=100, count=15, dev_id=3, transaction_id=5),
             ReadHoldingRegistersRequest(address=14, count=1, dev_id=3, transaction_id=6)]
    expected += [framer.buildFrame(request) for request in reads]
    assert asyncio.run(main()) == expected
