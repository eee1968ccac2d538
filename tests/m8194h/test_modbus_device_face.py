"""Machine data (manual 3.19), the function codes the device serves (Table 3, appendix 12)
and ET input register 86, over real Modbus: a raw client of our own over loopback TCP and a
pty pair (RTU), and mbpoll (libmodbus). The raw client sends the manual's frames byte for
byte, so no library stands between the test and the virtual controller."""

from __future__ import annotations

import asyncio
import json
import os
import select
import socket
import struct
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable, Coroutine
from pathlib import Path
from typing import Any, TypeVar

import pytest
from pymodbus.pdu import DecodePDU
from simproc import start_sim
from test_modbus import mbpoll, needs_mbpoll

from mplang.family.ptylink import PtyLink
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.ordered import MAX_QUEUED, FramerRTUInOrder, OrderedRequestHandler
from mplang.m8194h.sim.controller import VirtualController

# The manual's RSM_WRITE_MD frames (RS 2622-2650): MD100 = 0x12345678, MD1500 = 321.65
WRITE_MD100 = [0x0A27, 0x0000, 0x0064, 0x1234, 0x5678, 0x0000, 0x0000]
WRITE_MD1500 = [0x0A27, 0x0000, 0x05DC, 0x0000, 0x0000, 0x43A0, 0xD333]
T = TypeVar("T")
UNSUPPORTED = (7, 8, 11, 12, 17, 20, 21, 22, 23, 24, 43, 0x41, 0x64, 0x7F)


def fc16(address: int, values: list[int]) -> bytes:
    return struct.pack(f">BHHB{len(values)}H", 16, address, len(values), 2 * len(values),
                       *values)


def fc3(address: int, count: int) -> bytes:
    return struct.pack(">BHH", 3, address, count)


def fc4(address: int, count: int) -> bytes:
    return struct.pack(">BHH", 4, address, count)


def registers(answer: bytes) -> list[int]:
    """The registers of an FC3/FC4 answer PDU."""
    assert answer[0] in (3, 4) and answer[1] == len(answer) - 2, answer.hex()
    return list(struct.unpack(f">{answer[1] // 2}H", answer[2:]))


class RawTcp:
    """A blocking Modbus TCP client of a few lines: MBAP header, one request at a time."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.tid = 0

    def ask(self, pdu: bytes, unit: int = 1) -> bytes:
        self.tid += 1
        self.sock.sendall(struct.pack(">HHHB", self.tid, 0, len(pdu) + 1, unit) + pdu)
        header = self._exactly(7)
        tid, protocol, length, answered = struct.unpack(">HHHB", header)
        assert (tid, protocol, answered) == (self.tid, 0, unit)
        return self._exactly(length - 1)

    def _exactly(self, n: int) -> bytes:
        data = b""
        while len(data) < n:
            chunk = self.sock.recv(n - len(data))
            assert chunk, "the server closed the connection"
            data += chunk
        return data

    def close(self) -> None:
        self.sock.close()


def crc16(data: bytes) -> bytes:
    """Modbus RTU CRC (polynomial 0xA001, initial 0xFFFF), low byte first."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return struct.pack("<H", crc)


class RawRtu:
    """A blocking Modbus RTU master on one end of a pty pair (the link is raw already)."""

    def __init__(self, path: str, unit: int) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        self.unit = unit

    def ask(self, pdu: bytes) -> bytes:
        """Send one request; return the answer's PDU once a frame with a good CRC is in."""
        frame = bytes([self.unit]) + pdu
        os.write(self.fd, frame + crc16(frame))
        data = b""
        while not (len(data) >= 4 and crc16(data[:-2]) == data[-2:]):
            ready, _, _ = select.select([self.fd], [], [], 5)
            assert ready, f"no answer to {pdu.hex()} (got {data.hex()})"
            data += os.read(self.fd, 256)
        assert data[0] == self.unit
        return data[1:-2]

    def close(self) -> None:
        os.close(self.fd)


def served(speed: float = 50.0) -> DeviceFace:
    return DeviceFace(VirtualController(), SimClock(speed))


def over_tcp(test: Callable[[DeviceFace, int], Coroutine[Any, Any, None]]) -> None:
    """Run `test(face, port)` against a virtual controller served on a free loopback port."""
    async def scenario() -> None:
        face = served()
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            await test(face, port)
        finally:
            await stop(server)

    asyncio.run(scenario())


def check_md_manual_examples(ask: Callable[[bytes], bytes], vc: VirtualController) -> None:
    """RS 3.19.1 and 3.19.2, method 1 (sub-function) and method 2 (holding registers)."""
    assert ask(fc16(8000, WRITE_MD100)) == bytes.fromhex("101f400007")
    assert ask(fc16(8000, WRITE_MD1500)) == bytes.fromhex("101f400007")
    # "ldata: The response via MODBUS may be: 01 03 04 12 34 56 78" (RS 2549-2553)
    assert ask(fc3(0x0C80, 2)) == bytes.fromhex("030412345678")
    # "fdata: ... 01 03 04 43 A0 D3 33" (RS 2559-2563)
    assert ask(fc3(0x1770, 2)) == bytes.fromhex("030443a0d333")
    assert vc.md.read(100) == 0x12345678
    assert vc.md.read(1500) == pytest.approx(321.65, abs=1e-4)
    # method 2: the same values by FC16 at 3000 + 2n (RS 2653-2675)
    assert ask(fc16(0x0C82, [0xFFFF, 0xFFFE])) == bytes.fromhex("100c820002")
    assert ask(fc16(0x1772, [0x43A0, 0xD333])) == bytes.fromhex("1017720002")
    assert vc.md.read(101) == -2 and vc.md.read(1501) == vc.md.read(1500)
    assert registers(ask(fc3(0x0C80, 4))) == [0x1234, 0x5678, 0xFFFF, 0xFFFE]
    assert registers(ask(fc3(3000 + 2 * 2047, 2))) == [0, 0]  # MD2047, the last


def test_3_19_machine_data_manual_frames_over_tcp() -> None:
    async def test(face: DeviceFace, port: int) -> None:
        client = await asyncio.to_thread(RawTcp, port)
        try:
            await asyncio.to_thread(check_md_manual_examples, client.ask, face.controller)
        finally:
            client.close()

    over_tcp(test)


def over_rtu(talk: Callable[[RawRtu, DeviceFace], T]) -> tuple[DeviceFace, T]:
    """Run the blocking `talk(client, face)` against a virtual controller served as RTU
    slave 1 on a pty pair; the face and what `talk` returned."""
    async def scenario() -> tuple[DeviceFace, T]:
        face = served()
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=1)
            client = RawRtu(link.client_end, 1)
            try:
                return face, await asyncio.to_thread(talk, client, face)
            finally:
                client.close()
                await stop(server)

    return asyncio.run(scenario())


def test_3_19_machine_data_manual_frames_over_rtu() -> None:
    over_rtu(lambda client, face: check_md_manual_examples(client.ask, face.controller))


def test_12_2_2_word_order_holds_for_machine_data() -> None:
    """Holding register 14 orders every 32-bit value (RS 11445), MD included, both by the
    holding registers and in the RSM_WRITE_MD frame."""
    def steps(ask: Callable[[bytes], bytes], vc: VirtualController) -> None:
        assert ask(fc16(8000, WRITE_MD100)) == bytes.fromhex("101f400007")
        assert ask(fc16(14, [1])) == bytes.fromhex("10000e0001")
        assert registers(ask(fc3(3200, 2))) == [0x5678, 0x1234]  # LSW first now
        lsw_first = [0x0A27, 0x05DC, 0x0000, 0, 0, 0xD333, 0x43A0]  # MD1500 = 321.65
        assert ask(fc16(8000, lsw_first)) == bytes.fromhex("101f400007")
        assert registers(ask(fc3(6000, 2))) == [0xD333, 0x43A0]
        ask(fc16(6002, [0x0000, 0x3FC0]))  # 1.5, LSW first
        assert vc.md.read(1501) == 1.5

    async def test(face: DeviceFace, port: int) -> None:
        client = await asyncio.to_thread(RawTcp, port)
        try:
            await asyncio.to_thread(steps, client.ask, face.controller)
        finally:
            client.close()

    over_tcp(test)


def test_3_19_machine_data_refusals_carry_exception_and_cause() -> None:
    """MD takes two registers, "the first register must be addressed first" (RS 2528):
    exception 2 with cause 0xC0 (device profile registers.split_dword_*); an MD number
    outside MD0..MD2047 in RSM_WRITE_MD is cause 2 (RS 11368); inside a download the
    real-time RSM_WRITE_MD is cause 7."""
    def steps(ask: Callable[[bytes], bytes], vc: VirtualController) -> None:
        def cause() -> int:
            return registers(ask(fc4(102, 1)))[0]

        assert ask(fc3(3001, 2)) == bytes([0x83, 0x02]) and cause() == 0xC0
        assert ask(struct.pack(">BHH", 6, 3000, 7)) == bytes([0x86, 0x02])
        assert ask(fc16(3000, [0, 1, 2])) == bytes([0x90, 0x02])
        assert ask(fc3(2998, 4)) == bytes([0x83, 0x02])  # 2998-2999 are no registers
        assert ask(fc3(7096, 2)) == bytes([0x83, 0x02])  # after MD2047
        beyond = [0x0A27, 0x0000, 2048, 0, 1, 0, 0]
        assert ask(fc16(8000, beyond)) == bytes([0x90, 0x01]) and cause() == 0x02
        assert ask(fc16(8000, [0x0A27, 0xFFFF, 0xFFFF, 0, 1, 0, 0])) == bytes([0x90, 0x01])
        assert ask(fc16(8000, WRITE_MD100)) == bytes.fromhex("101f400007") and cause() == 0
        assert ask(fc16(8000, [0x0AC9, 41])) == bytes.fromhex("101f400002")  # MP_CREATE 41
        assert ask(fc16(8000, WRITE_MD1500)) == bytes([0x90, 0x01]) and cause() == 0x07
        assert vc.md.read(1500) == 0.0 and vc.md.read(100) == 0x12345678

    async def test(face: DeviceFace, port: int) -> None:
        client = await asyncio.to_thread(RawTcp, port)
        try:
            await asyncio.to_thread(steps, client.ask, face.controller)
        finally:
            client.close()

    over_tcp(test)


@needs_mbpoll
def test_3_19_mbpoll_writes_and_reads_machine_data() -> None:
    """libmodbus as an independent client: 32-bit ints and floats, MSW first (-B)."""
    async def test(face: DeviceFace, port: int) -> None:
        tcp = ("-m", "tcp", "-p", str(port), "-a", "1")
        await mbpoll(*tcp, "-t", "4:int", "-B", "-r", "3200", "127.0.0.1", "305419896")
        await mbpoll(*tcp, "-t", "4:float", "-B", "-r", "6000", "127.0.0.1", "321.65")
        assert face.controller.md.read(100) == 0x12345678
        assert face.controller.md.word(1500) == 0x43A0D333  # the manual's example bits
        out = await mbpoll(*tcp, "-t", "4:int", "-B", "-r", "3200", "-c", "1", "127.0.0.1")
        assert "[3200]: \t305419896" in out
        out = await mbpoll(*tcp, "-t", "4:float", "-B", "-r", "6000", "-c", "1", "127.0.0.1")
        assert "[6000]: \t321.65" in out

    over_tcp(test)


def test_3_19_machine_data_survive_an_mpc_sim_restart(tmp_path: Path) -> None:
    """MD "are stored in a non-volatile memory" (RS 2507): `mpc sim --memory` keeps them;
    a memory file written before MD existed still loads, with every MD 0."""
    memory = tmp_path / "fram.json"
    proc, port = start_sim("--memory", str(memory))
    try:
        client = RawTcp(port)
        assert client.ask(fc16(8000, WRITE_MD100)) == bytes.fromhex("101f400007")
        assert client.ask(fc16(6000, [0x43A0, 0xD333])) == bytes.fromhex("1017700002")
        client.close()
    finally:
        proc.terminate()
        assert proc.wait(10) == 0
    saved = json.loads(memory.read_text())
    assert saved["machine_data"] == {"MD100": 0x12345678, "MD1500": 321.65}
    proc, port = start_sim("--memory", str(memory))
    try:
        client = RawTcp(port)
        assert registers(client.ask(fc3(3200, 2))) == [0x1234, 0x5678]
        assert registers(client.ask(fc3(6000, 2))) == [0x43A0, 0xD333]
        client.close()
    finally:
        proc.terminate()
        assert proc.wait(10) == 0
    del saved["machine_data"]  # as written before machine data were kept
    memory.write_text(json.dumps(saved))
    old = subprocess.run([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                          "--memory", str(memory), "--duration", "0.2"],
                         capture_output=True, text=True, timeout=30)
    assert old.returncode == 0, old.stdout + old.stderr
    saved["machine_data"] = {"MD1500": "x"}
    memory.write_text(json.dumps(saved))
    bad = subprocess.run([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                          "--memory", str(memory), "--duration", "0.2"],
                         capture_output=True, text=True, timeout=30)
    assert bad.returncode == 3 and "machine_data.MD1500" in bad.stderr
    assert "Traceback" not in bad.stderr


# ------------------------------------------------------------------------ function codes


def check_function_codes(ask: Callable[[bytes], bytes]) -> None:
    """Only FC 1-6, 15, 16 are served (RS 11206, 11414, 11822-11826, 11990); any other is
    ILLEGAL FUNCTION (Table 3, RS 938) with register 102 = 1 (RS 11366), and nothing in the
    answer names the server's software."""
    for fc in UNSUPPORTED:
        assert ask(fc4(27, 2)) == bytes([0x84, 0x02])  # sets register 102 to 0xC0 first
        answer = ask(bytes([fc, 0x00, 0x00, 0x00, 0x01]))
        assert answer == bytes([fc | 0x80, 0x01]), (fc, answer.hex())
        assert registers(ask(fc4(102, 1))) == [1], fc
    assert ask(bytes([17])) == bytes([0x91, 0x01])  # report server id: no "pymodbus"
    assert ask(bytes([43, 0x0E, 0x01, 0x00])) == bytes([0xAB, 0x01])  # device identification
    # the served ones still answer
    assert ask(bytes([1, 0, 0, 0, 8])) == bytes([1, 1, 0])
    assert ask(bytes([2, 0, 0, 0, 8])) == bytes([2, 1, 0])
    assert ask(bytes([5, 0, 3, 0xFF, 0])) == bytes([5, 0, 3, 0xFF, 0])
    assert ask(bytes([15, 0, 0, 0, 2, 1, 1])) == bytes([15, 0, 0, 0, 2])
    assert ask(struct.pack(">BHH", 6, 14, 0)) == struct.pack(">BHH", 6, 14, 0)
    assert registers(ask(fc3(0, 1))) == [0b1001]  # DO 0 and 3 from the coil writes


def test_table_3_only_the_manuals_function_codes_over_tcp() -> None:
    async def test(_face: DeviceFace, port: int) -> None:
        client = await asyncio.to_thread(RawTcp, port)
        try:
            await asyncio.to_thread(check_function_codes, client.ask)
        finally:
            client.close()

    over_tcp(test)


def test_table_3_only_the_manuals_function_codes_over_rtu() -> None:
    received: list[bytes] = []

    def heard(sending: bool, data: bytes) -> bytes:
        if not sending:
            received.append(data)
        return data

    def other_slave(client: RawRtu) -> None:
        """FC17 for slave 9 leaves slave 2's register 102 alone (and gets no answer)."""
        assert client.ask(fc4(27, 2)) == bytes([0x84, 0x02])
        request = b"\x09\x11" + crc16(b"\x09\x11")
        os.write(client.fd, request)
        for _ in range(500):  # until the device has taken it in (one request at a time)
            if request in b"".join(received):
                break
            time.sleep(0.01)
        assert registers(client.ask(fc4(102, 1))) == [0xC0]

    async def scenario() -> None:
        face = served()
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=2, trace_packet=heard)
            client = RawRtu(link.client_end, 2)
            try:
                await asyncio.to_thread(check_function_codes, client.ask)
                await asyncio.to_thread(other_slave, client)
            finally:
                client.close()
                await stop(server)

    asyncio.run(scenario())


def test_table_3_a_split_32_bit_access_is_exception_2_with_cause_c0() -> None:
    """RS 939: a two-register value must be addressed at its first register, or the
    answer is MB_ILLEGAL_DATA_ADDRESS (2); register 102 says 0xC0 (RS 11368)."""
    def steps(ask: Callable[[bytes], bytes]) -> None:
        assert ask(fc4(27, 2)) == bytes([0x84, 0x02])  # LSW of X's LP, MSW of Y's
        assert registers(ask(fc4(102, 1))) == [0xC0]
        assert ask(struct.pack(">BHH", 6, 300, 5)) == bytes([0x86, 0x02])  # half of VAR0
        assert ask(fc16(301, [1, 2])) == bytes([0x90, 0x02])
        assert ask(fc3(82, 1)) == bytes([0x83, 0x02])
        assert registers(ask(fc3(300, 2))) == [0, 0]  # nothing was written

    async def test(_face: DeviceFace, port: int) -> None:
        client = await asyncio.to_thread(RawTcp, port)
        try:
            await asyncio.to_thread(steps, client.ask)
        finally:
            client.close()

    over_tcp(test)


def test_et_12_1_9_input_86_counts_the_connected_tcp_clients() -> None:
    """ET 18559: input register 86, TCN, "Total Modbus Client Connection Number"."""
    def steps(port: int) -> None:
        first = RawTcp(port)
        assert registers(first.ask(fc4(86, 1))) == [1]
        second = RawTcp(port)
        assert registers(second.ask(fc4(86, 1))) == [2]
        assert registers(first.ask(fc4(84, 3))) == [0x0221, 0x0201, 2]
        second.close()
        for _ in range(500):  # the server sees the close on its next turn
            if registers(first.ask(fc4(86, 1))) == [1]:
                break
        assert registers(first.ask(fc4(86, 1))) == [1]
        first.close()

    async def test(_face: DeviceFace, port: int) -> None:
        await asyncio.to_thread(steps, port)

    over_tcp(test)


# ------------------------------------------------- requests that arrive in one read
PAIR_ANSWERS = [fc16(300, [0, 77]), bytes([3, 4, 0, 0, 0, 77])]
"""A VAR0 write and its read-back sent in one write: the answers the device owes, in order
(FC16 echoes address and count)."""


def test_two_requests_in_one_tcp_segment_are_both_served_in_order() -> None:
    """pymodbus's server took one request per read and dropped the rest when it answered;
    a real device serves every request of its connection, in order."""
    async def test(face: DeviceFace, port: int) -> None:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        pdus = [fc16(300, [0, 77]), fc3(300, 2)]
        writer.write(b"".join(struct.pack(">HHHB", tid, 0, len(pdu) + 1, 1) + pdu
                              for tid, pdu in enumerate(pdus, start=1)))
        answers = []
        for tid in (1, 2):
            header = await asyncio.wait_for(reader.readexactly(7), 5)
            assert struct.unpack(">HHHB", header)[0] == tid
            answers.append(await reader.readexactly(header[5] - 1))
        writer.close()
        assert answers[0] == fc16(300, [0, 77])[:5]
        assert answers[1] == PAIR_ANSWERS[1]
        assert face.requests == 2

    over_tcp(test)


def test_two_rtu_frames_in_one_read_are_both_served_in_order() -> None:
    """The RTU framer used up the whole read for its first frame: a frame repeated by a
    relay right before the next one stored a line twice and lost the next, under an answer
    count that came out even (docs/flash-faults.md)."""
    def ask_both(client: RawRtu) -> list[bytes]:
        frames = [bytes([1]) + pdu for pdu in (fc16(300, [0, 77]), fc3(300, 2))]
        os.write(client.fd, b"".join(frame + crc16(frame) for frame in frames))
        data = b""
        while len(data) < 8 + 9:  # the FC16 echo (8 bytes) and 2 registers (9 bytes)
            ready, _, _ = select.select([client.fd], [], [], 5)
            assert ready, f"answers missing (got {data.hex()})"
            data += os.read(client.fd, 256)
        return [data[1:6], data[9:15]]

    face, answers = over_rtu(lambda client, _face: ask_both(client))
    assert answers == [PAIR_ANSWERS[0][:5], PAIR_ANSWERS[1]]
    assert face.requests == 2


def test_an_rtu_frame_with_a_bad_crc_is_skipped_and_the_next_one_in_the_read_served() -> None:
    """A corrupted frame is ignored, as a real slave ignores it, and does not take the
    good frame behind it in the same read with it."""
    def corrupted_then_good(client: RawRtu) -> bytes:
        bad = bytes([1]) + fc16(300, [0, 5])
        good = bytes([1]) + fc3(300, 2)
        crc = crc16(bad)
        os.write(client.fd, bad + bytes([crc[0] ^ 0xFF, crc[1]]) + good + crc16(good))
        data = b""
        while len(data) < 9:  # the read's answer: unit, FC3, byte count, 2 registers, CRC
            ready, _, _ = select.select([client.fd], [], [], 5)
            assert ready, f"no answer (got {data.hex()})"
            data += os.read(client.fd, 256)
        return data

    face, answer = over_rtu(lambda client, _face: corrupted_then_good(client))
    assert answer[1:-2] == bytes([3, 4, 0, 0, 0, 0]), answer.hex()  # VAR0 was not written
    assert face.requests == 1


def test_rtu_line_noise_is_used_up_not_kept() -> None:
    """Bytes that cannot start a frame any more are used up at once (kept, they would be
    scanned again on every read and grow without bound); a frame's start is kept until its
    rest arrives, and a frame after the noise is still decoded."""
    framer = FramerRTUInOrder(DecodePDU(True))
    noise = bytes([0xFF] * 200)
    used, _unit, _tid, pdu = framer.decode(noise)
    assert pdu == b"" and 200 - used <= framer.MIN_SIZE  # at most a possible start kept
    frame = bytes([1]) + fc3(300, 2)
    frame += crc16(frame)
    used, _unit, _tid, pdu = framer.decode(noise + frame[:5])
    assert used <= 200 and pdu == b""  # the frame's start is kept
    used, unit, _tid, pdu = framer.decode(noise + frame)
    assert (used, unit, pdu) == (200 + len(frame), 1, frame[1:-2])


def test_a_client_that_never_reads_cannot_queue_without_bound() -> None:
    """A connection's decoded requests wait in a queue of at most MAX_QUEUED."""
    handler = OrderedRequestHandler.__new__(OrderedRequestHandler)
    handler._queue = deque()
    handler._worker = None
    handler.framer = FramerRTUInOrder(DecodePDU(True))
    handler.trace_packet = lambda _sending, data: data
    handler.trace_pdu = lambda _sending, pdu: pdu
    frame = bytes([1]) + fc3(300, 2)
    frame += crc16(frame)

    async def flood() -> int:
        handler._worker = asyncio.get_running_loop().create_future()  # busy: not drained
        return handler.callback_data(frame * (MAX_QUEUED + 50))

    used = asyncio.run(flood())
    assert used == len(frame) * (MAX_QUEUED + 50)
    assert len(handler._queue) == MAX_QUEUED
