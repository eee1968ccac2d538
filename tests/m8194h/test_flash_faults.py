"""Fault injection for `mpc flash`: what a real link and a real device do wrong, against the
virtual M8194H over loopback Modbus TCP and Modbus RTU on a pty pair.

Faults sit where they happen on a real installation: in a TCP proxy between the client and
the device (`TcpFaultProxy`: answers dropped, delayed or cut, connections reset), in the RTU
device's packet stream (`RtuFaults`: answers dropped or delayed, CRCs corrupted in either
direction) and in the device's answers (`DeviceFace(..., interpose=...)`: busy, refusals).
tests/m8194h/test_flash.py holds the cases this file does not repeat: a dropped answer and a reset
after the answer, busy answers to one frame, refusals, a device left in MP download state.

Every case ends one of two ways, and `assert_settled` checks both: every program verified and
stored exactly as built (no line missing, none stored twice), or a failure with the outcome
(exit code) the fault calls for. Either way the device is ready, not in download state, and
holds no half program in a slot the flash touched.
"""

from __future__ import annotations

import asyncio
import os
import sys
import time
from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from loopback import LoopbackServer

from mplang.cli.common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_REJECTED,
    FLASH_EXIT,
)
from mplang.family.ptylink import PtyLink
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.flash import Flasher, FlashImage, FlashOptions, FlashReport, image_from_build
from mplang.m8194h.modbus import DeviceLink, Endpoint, LinkTimeout
from mplang.m8194h.modbus_server import DeviceFace, Interpose, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

READ_HOLDING, READ_INPUT, WRITE_REGISTERS = 3, 4, 16
FRAME_WINDOW = 8000
# The client's answer timeout: a round trip takes about 1 ms here. TIMEOUT where a late
# answer must land inside a time window, QUICK where any timeout will do.
TIMEOUT, QUICK = 0.2, 0.1
# where a test counts downloads exactly and a timeout only ends a wait the fault makes (not
# a lost frame): long enough that a slow answer on a loaded machine is not taken for a lost one
STEADY = 1.0
LATE = 1.5 * TIMEOUT  # a late answer: after the client gave up, within twice its timeout
# later than the quiet time a link keeps after a timeout, while the next request (sent when
# that quiet time ends, its own answer queued behind the late one) still waits
VERY_LATE = 2.5 * TIMEOUT

# Image order MP22, MP41, ISR7; FC16 frames 0-3, 4-11 and 12-15. MP41's ARC_CW takes two
# slot lines, so its FOR is on slot line 3. Running MP41 sets VAR1 = 3, VAR2 = 30.
JOB = """MP 41 counter
    SET_V XY, 1000
    ARC_CW 0, 1000, 0, 2000
    FOR 3
        VAR1 = VAR1 + 1
    NEXT
    VAR2 = VAR1 * 10
END MP
ISR 7 on_edge
    VAR5 = VAR5 + 1
    VAR6 = 2
END ISR
MP 22 pause
    TIMER 10
    VAR7 = 7
END MP
"""
MP22_CREATE, MP41_CREATE, MP41_FOR, MP41_CLOSE, ISR7_CREATE = 0, 4, 7, 11, 12
MP41, ISR7 = 1, 2  # their places in the image


def job_image() -> FlashImage:
    build = compile_source(JOB, "job.mp")
    assert build.ok, [d.render() for d in build.diagnostics]
    image = image_from_build(build)
    assert [p.label for p in image.programs] == ["MP22 pause", "MP41 counter", "ISR7 on_edge"]
    return image


def device(interpose: Interpose | None = None) -> DeviceFace:
    return DeviceFace(VirtualController(), SimClock(1.0), interpose)


# ------------------------------------------------------------------------------ requests
@dataclass(frozen=True)
class Request:
    """One Modbus request as the device received it. `frame` numbers the FC16 writes to the
    sub-function window (0, 1, ...), None for any other request."""

    index: int
    function_code: int
    address: int
    count: int
    values: tuple[int, ...]
    frame: int | None


def parse_request(pdu: bytes, index: int, frame: int | None) -> Request:
    """A request PDU (function code first) of the kinds the flasher sends."""
    function_code = pdu[0]
    address = int.from_bytes(pdu[1:3], "big")
    count = int.from_bytes(pdu[3:5], "big")
    values: tuple[int, ...] = ()
    if function_code == WRITE_REGISTERS:
        values = tuple(int.from_bytes(pdu[6 + 2 * k:8 + 2 * k], "big") for k in range(count))
    return Request(index, function_code, address, count, values, frame)


FAULTS = ("drop", "late", "reset", "half-answer", "bad-crc-answer", "bad-crc-request")
"""What a `Plan` may do to one request: drop its answer; send the answer `late_by` seconds
late (answers after it wait behind it, as in a device that serves one request at a time);
reset the TCP connection before the request reaches the device; send half the answer and
reset; corrupt the RTU CRC of the answer, or of the request (the device then ignores it)."""

Plan = Callable[[Request], str | None]


@dataclass
class Faults:
    """Decides, per request, which fault (if any) hits it, and records what fired."""

    plan: Plan
    requests: list[Request] = field(default_factory=list)
    fired: list[tuple[str, Request]] = field(default_factory=list)
    frames: int = 0

    def next_request(self, pdu: bytes) -> tuple[Request, str | None]:
        function_code = pdu[0]
        address = int.from_bytes(pdu[1:3], "big")
        frame = None
        if function_code == WRITE_REGISTERS and address == FRAME_WINDOW:
            frame, self.frames = self.frames, self.frames + 1
        request = parse_request(pdu, len(self.requests), frame)
        self.requests.append(request)
        fault = self.plan(request)
        assert fault is None or fault in FAULTS, fault
        if fault is not None:
            self.fired.append((fault, request))
        return request, fault

    def kinds(self) -> list[str]:
        return [fault for fault, _request in self.fired]


def at_frame(frame: int, fault: str) -> Plan:
    """`fault` once, on FC16 frame number `frame` of the whole run."""
    return lambda request: fault if request.frame == frame else None


def at_read(address: int, count: int, fault: str, nth: int = 0) -> Plan:
    """`fault` once, on the `nth` read of `count` input registers from `address`."""
    seen: list[Request] = []

    def plan(request: Request) -> str | None:
        if (request.function_code, request.address, request.count) != \
                (READ_INPUT, address, count):
            return None
        seen.append(request)
        return fault if len(seen) == nth + 1 else None

    return plan


def whenever(values: list[int], fault: str) -> Plan:
    """`fault` every time the frame `values` is written: a fault that does not go away."""
    return lambda request: fault if list(request.values) == values and \
        request.frame is not None else None


# ------------------------------------------------------------------------------ TCP proxy
class TcpFaultProxy(LoopbackServer):
    """A Modbus TCP proxy on a loopback port between the client and the device, one device
    connection per client connection, one request at a time (MBAP framing)."""

    def __init__(self, device_port: int, plan: Plan, late_by: float = LATE) -> None:
        super().__init__()
        self.device_port = device_port
        self.faults = Faults(plan)
        self.late_by = late_by
        self.late_delivered = 0  # late answers written to a connection the client kept
        self.late_lost = 0  # late answers whose connection the client had closed
        self.late_pending = 0  # late answers not sent yet

    @staticmethod
    async def _read_adu(reader: asyncio.StreamReader) -> bytes:
        header = await reader.readexactly(7)
        return header + await reader.readexactly(int.from_bytes(header[4:6], "big") - 1)

    async def _serve(self, client_reader: asyncio.StreamReader,
                     client_writer: asyncio.StreamWriter) -> None:
        device_reader, device_writer = await asyncio.open_connection("127.0.0.1",
                                                                     self.device_port)
        held: list[bytes] = []
        gone = asyncio.Event()  # the client closed this connection
        try:
            while True:
                try:
                    request = await self._read_adu(client_reader)
                except (asyncio.IncompleteReadError, ConnectionError):
                    return
                _request, fault = self.faults.next_request(request[7:])
                assert fault not in ("bad-crc-answer", "bad-crc-request"), "RTU only"
                if fault == "reset":
                    client_writer.transport.abort()
                    return
                device_writer.write(request)
                answer = await self._read_adu(device_reader)
                if fault == "drop":
                    continue
                if fault == "half-answer":
                    client_writer.write(answer[:len(answer) // 2])
                    await client_writer.drain()
                    client_writer.transport.abort()
                    return
                if held or fault == "late":
                    held.append(answer)
                    if fault == "late" and len(held) == 1:
                        self.late_pending += 1
                        self._later(client_writer, held, gone)
                    continue
                client_writer.write(answer)
        finally:
            gone.set()
            device_writer.close()
            if not held:
                client_writer.close()

    def _later(self, writer: asyncio.StreamWriter, held: list[bytes],
               gone: asyncio.Event) -> None:
        async def release() -> None:
            await asyncio.sleep(self.late_by)
            if gone.is_set():
                self.late_lost += 1
            else:
                self.late_delivered += 1
                writer.write(b"".join(held))
            held.clear()
            writer.close()
            self.late_pending -= 1

        self._spawn(release())


# ----------------------------------------------------------------------------- RTU faults
def rtu_request_length(data: bytes) -> int | None:
    """The length of the RTU request at the start of `data`, None until enough has come."""
    if len(data) < 2:
        return None
    if data[1] in (15, 16):
        return 9 + data[6] if len(data) >= 7 else None
    return 8


def crc_corrupted(frame: bytes) -> bytes:
    return frame[:-1] + bytes([frame[-1] ^ 0x5A])


class RtuFaults:
    """The RTU device's packet hook (`serve_rtu(trace_packet=...)`). A late answer is written
    onto the line through a second descriptor of the device's end of the pty pair."""

    def __init__(self, plan: Plan, late_by: float = LATE) -> None:
        self.faults = Faults(plan)
        self.late_by = late_by
        self.late_pending = 0  # late answers not sent yet
        self._answer_fault: str | None = None
        self._held: list[bytes] = []
        self._line: int | None = None

    @contextmanager
    def attached(self, device_end: str) -> Iterator[RtuFaults]:
        self._line = os.open(device_end, os.O_WRONLY | os.O_NOCTTY)
        try:
            yield self
        finally:
            os.close(self._line)
            self._line = None

    def __call__(self, sending: bool, data: bytes) -> bytes:
        if not sending:
            length = rtu_request_length(data)
            if length is None or len(data) < length:
                return data  # a partial frame: the hook sees it again when it is whole
            _request, fault = self.faults.next_request(data[1:length - 2])
            assert fault not in ("reset", "half-answer"), "TCP only"
            if fault == "bad-crc-request":
                return crc_corrupted(data[:length]) + data[length:]
            self._answer_fault = fault
            return data
        fault, self._answer_fault = self._answer_fault, None
        if self._held:
            self._held.append(data)
            return b""
        if fault == "drop":
            return b""
        if fault == "bad-crc-answer":
            return crc_corrupted(data)
        if fault == "late":
            self._held.append(data)
            self.late_pending += 1
            asyncio.get_running_loop().call_later(self.late_by, self._release)
            return b""
        return data

    def _release(self) -> None:
        assert self._line is not None
        for answer in self._held:
            os.write(self._line, answer)
        self._held.clear()
        self.late_pending -= 1


# ----------------------------------------------------------------------- running a flash
Injector = TcpFaultProxy | RtuFaults


@asynccontextmanager
async def faulty_link(transport: str, face: DeviceFace, plan: Plan, timeout: float = TIMEOUT,
                      retries: int = 3, late_by: float = LATE,
                      ) -> AsyncIterator[tuple[Injector, Endpoint]]:
    """`face` served over `transport` ("tcp": behind a TcpFaultProxy; "rtu": on a pty pair
    with RtuFaults), and the endpoint a client uses to reach it."""
    if transport == "tcp":
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        proxy = TcpFaultProxy(port, plan, late_by)
        try:
            proxy_port = await proxy.start()
            yield proxy, Endpoint(host="127.0.0.1", port=proxy_port, timeout=timeout,
                                  retries=retries)
        finally:
            await proxy.close()
            await stop(server)
        return
    faults = RtuFaults(plan, late_by)
    with PtyLink() as link, faults.attached(link.device_end):
        rtu_server = await serve_rtu(face, link.device_end, unit=1, trace_packet=faults)
        try:
            yield faults, Endpoint(serial=link.client_end, timeout=timeout, retries=retries)
        finally:
            await stop(rtu_server)


@dataclass
class Run:
    report: FlashReport
    link: DeviceLink
    injector: Injector

    @property
    def faults(self) -> Faults:
        return self.injector.faults


def flash_through(transport: str, face: DeviceFace, plan: Plan, image: FlashImage,
                  options: FlashOptions | None = None, timeout: float = QUICK,
                  retries: int = 3) -> Run:
    """Flash `image` into `face` over `transport` ("tcp" or "rtu") with `plan`'s faults."""

    async def scenario() -> Run:
        async with faulty_link(transport, face, plan, timeout, retries) as (injector, endpoint):
            link = DeviceLink(endpoint)
            report = await Flasher(image, link, options or FlashOptions()).run()
            deadline = time.monotonic() + LATE
            while injector.late_pending and time.monotonic() < deadline:
                await asyncio.sleep(0.01)  # a late answer reaches the link, closed by now
            return Run(report, link, injector)

    return asyncio.run(scenario())


def stored(face: DeviceFace, kind: str, slot: int) -> list[list[int]] | None:
    table = face.controller.tables.get((kind, slot))
    return None if table is None else [list(line.frame) for line in table.lines]


def assert_settled(face: DeviceFace, image: FlashImage, report: FlashReport) -> None:
    """The invariant of every fault: the device is ready; a verified program is stored
    exactly as built; a program that failed left nothing runnable but its complete self or
    an empty slot; a program never sent was not stored (the device started empty)."""
    vc = face.controller
    assert vc.state == "ready" and vc.pending is None, f"left in {vc.state} download state"
    assert report.ok == all(p.status == "verified" for p in report.programs)
    assert report.ok == (report.outcome == "verified")
    for program, result in zip(image.programs, report.programs, strict=True):
        content = stored(face, program.kind, program.slot)
        if result.status == "verified":
            assert content == program.frames[1:-1], program.label
        elif result.status == "pending":
            assert content is None, program.label
        else:
            assert content in (None, [], program.frames[1:-1]), \
                f"{program.label} holds a half program: {content}"


def assert_runs(face: DeviceFace) -> None:
    """The flashed job does what it was written to do on the device that holds it."""
    vc = face.controller
    vc.call(41)
    assert vc.run().finished
    vc.call(7, "isr")
    assert vc.run().finished
    assert (vc.vars[1], vc.vars[2], vc.vars[5], vc.vars[6]) == (3, 30, 1, 2)


def downloads(report: FlashReport) -> list[int]:
    return [p.downloads for p in report.programs]


# ------------------------------------------------------------------- late answers: flash
# a plan counts requests, so each case makes a fresh one
LATE_CASES: dict[str, tuple[Callable[[], Plan], list[int]]] = {
    "line frame": (lambda: at_frame(MP41_FOR, "late"), [1, 2, 1]),
    "status read": (lambda: at_read(100, 15, "late", nth=1), [1, 1, 1]),
}


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
@pytest.mark.parametrize("case", list(LATE_CASES))
def test_late_answer_is_never_taken_for_a_later_request(transport: str, case: str) -> None:
    """The answer comes after the client gave up: the flash goes on as after a lost answer
    (a frame's program is downloaded again, a read repeated) and the late answer reaches no
    later request: over TCP it arrives on the connection the client closed, over RTU (no
    connections, no transaction ids) into the port the client keeps closed for a while."""
    make_plan, expected_downloads = LATE_CASES[case]
    image = job_image()
    face = device()
    run = flash_through(transport, face, make_plan(), image, timeout=TIMEOUT)
    assert run.faults.kinds() == ["late"] and run.injector.late_pending == 0
    assert run.report.ok, run.report.error
    assert FLASH_EXIT[run.report.outcome] == EXIT_OK
    assert downloads(run.report) == expected_downloads
    assert run.link.foreign_answers == 0 and run.link.anomalies == 0
    assert run.link.fences + run.link.quiet_fences >= 1
    if isinstance(run.injector, TcpFaultProxy):
        # the connection is kept: the late answer arrives on it before the fence's answer,
        # matched to its abandoned request by transaction id
        assert (run.injector.late_lost, run.injector.late_delivered) == (0, 1)
    assert_settled(face, image, run.report)
    assert_runs(face)


# --------------------------------------------------------------- late answers: the link
def at_read_holding(address: int, count: int) -> Plan:
    """`late` once, on the first read of `count` holding registers from `address`."""
    fired: list[Request] = []

    def plan(request: Request) -> str | None:
        if (request.function_code, request.address, request.count) == \
                (READ_HOLDING, address, count) and not fired:
            fired.append(request)
            return "late"
        return None

    return plan


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_late_answer_with_an_old_value_is_not_returned_for_a_new_read(transport: str) -> None:
    """A read that timed out, a variable that changed, the same read again: the answer is
    the new value, not the late answer to the first read (same function, same count)."""
    face = device()
    face.controller.vars[1] = 111

    async def scenario() -> tuple[list[int], DeviceLink]:
        plan = at_read_holding(302, 2)  # VAR1
        async with faulty_link(transport, face, plan, retries=0) as (_injector, endpoint):
            link = DeviceLink(endpoint)
            await link.open()
            with pytest.raises(LinkTimeout):
                await link.read_holding(302, 2)
            face.controller.vars[1] = 222
            values = await link.read_holding(302, 2)
            link.close()
            return values, link

    values, link = asyncio.run(scenario())
    assert values == [0, 222]
    assert link.foreign_answers == 0 and link.anomalies == 0


def test_very_late_answer_of_another_shape_is_refused_over_rtu() -> None:
    """An answer far later than the timeout: over RTU only its shape tells it from the
    answer being waited for. The next request fences first, and the fence's barrier read
    (a register count nothing else reads) meets the 15 registers, not the read of one."""
    face = device()
    face.controller.illegal_cause = 0x42  # input register 102; register 100 reads 0

    async def scenario() -> tuple[list[int], DeviceLink]:
        plan = at_read(100, 15, "late")
        async with faulty_link("rtu", face, plan, retries=0, late_by=VERY_LATE) \
                as (_injector, endpoint):
            link = DeviceLink(endpoint)
            await link.open()
            with pytest.raises(LinkTimeout):
                await link.read_input(100, 15)
            value = await link.read_input(102, 1)  # fences past the late answer first
            link.close()
            return value, link

    value, link = asyncio.run(scenario())
    assert value == [0x42]
    assert link.foreign_answers == 0 and link.absorbed + link.quiet_fences >= 1


def test_very_late_exception_answer_is_not_taken_for_a_read_over_rtu() -> None:
    """A refusal (exception 0x01 to an FC16) that arrives during the fence is not the
    barrier's answer; the read after it gives register 102, the refused frame's cause."""
    face = device()
    # refused outside a download (MP_CLOSE there is ignored, RS 9886; MP_ISR_CLOSE is not)
    close = face.controller.encoder.close_frame("isr")

    async def scenario() -> tuple[list[int], DeviceLink]:
        async with faulty_link("rtu", face, at_frame(0, "late"), retries=0,
                               late_by=VERY_LATE) as (_injector, endpoint):
            link = DeviceLink(endpoint)
            await link.open()
            with pytest.raises(LinkTimeout):
                await link.write_frame(close)
            cause = await link.read_input(102, 1)
            link.close()
            return cause, link

    cause, link = asyncio.run(scenario())
    assert [r.code for r in face.refusals] == [0x01]  # the device did refuse the frame ...
    assert cause == [0x08]  # ... with cause 8: a macro command outside a download
    assert link.foreign_answers == 0 and link.absorbed + link.quiet_fences >= 1


# ------------------------------------------------------------------------- corrupted CRC
CRC_CASES: dict[str, tuple[Callable[[], Plan], list[int]]] = {
    # the device stored the frame, the client cannot know: the program is downloaded again
    "answer to a line frame": (lambda: at_frame(MP41_FOR, "bad-crc-answer"), [1, 2, 1]),
    "answer to a close frame": (lambda: at_frame(MP41_CLOSE, "bad-crc-answer"), [1, 2, 1]),
    "answer to a status read": (lambda: at_read(100, 15, "bad-crc-answer"), [1, 1, 1]),
    # the device ignores the request; to the client it is the same silence
    "request of a create frame": (lambda: at_frame(MP22_CREATE, "bad-crc-request"),
                                  [2, 1, 1]),
    "request of a line frame": (lambda: at_frame(MP41_FOR, "bad-crc-request"), [1, 2, 1]),
    "request of a close frame": (lambda: at_frame(MP41_CLOSE, "bad-crc-request"), [1, 2, 1]),
    "request of a status read": (lambda: at_read(100, 1, "bad-crc-request", nth=2),
                                 [1, 1, 1]),
}


@pytest.mark.parametrize("case", list(CRC_CASES))
def test_corrupted_rtu_crc_is_a_lost_frame_never_a_wrong_one(case: str) -> None:
    make_plan, expected_downloads = CRC_CASES[case]
    image = job_image()
    face = device()
    run = flash_through("rtu", face, make_plan(), image)
    assert len(run.faults.fired) == 1
    assert run.report.ok, run.report.error
    assert downloads(run.report) == expected_downloads
    assert_settled(face, image, run.report)
    assert_runs(face)
    # the device served every request but a corrupted one, which it never saw
    ignored = 1 if run.faults.kinds() == ["bad-crc-request"] else 0
    assert face.requests == len(run.faults.requests) - ignored


# ---------------------------------------------------------------------- connection reset
@pytest.mark.parametrize("fault", ["reset", "half-answer"],
                         ids=["before the request reaches the device", "halfway through "
                              "the answer"])
@pytest.mark.parametrize("frame", [MP41_CREATE, MP41_FOR, MP41_CLOSE])
def test_connection_reset_mid_program_downloads_it_again(fault: str, frame: int) -> None:
    image = job_image()
    face = device()
    run = flash_through("tcp", face, at_frame(frame, fault), image, timeout=STEADY)
    assert run.faults.kinds() == [fault]
    assert run.report.ok, run.report.error
    assert downloads(run.report) == [1, 2, 1]
    assert any("connection lost" in note for note in run.report.notes)
    assert_settled(face, image, run.report)
    assert_runs(face)


def test_connection_reset_during_the_repair_of_a_cut_download() -> None:
    """Two faults in a row: the answer to a line is lost, then the connection resets on the
    close frame that repairs the open download. The next attempt repairs it again."""
    image = job_image()
    face = device()
    close = image.programs[MP41].frames[-1]
    resets: list[Request] = []

    def plan(request: Request) -> str | None:
        if request.frame == MP41_FOR:
            return "drop"
        if list(request.values) == close and request.frame == MP41_FOR + 1 and not resets:
            resets.append(request)
            return "reset"
        return None

    run = flash_through("tcp", face, plan, image)
    assert run.faults.kinds() == ["drop", "reset"]
    assert run.report.ok, run.report.error
    assert downloads(run.report) == [1, 2, 1]
    assert_settled(face, image, run.report)


# ---------------------------------------------------------------------------------- busy
def test_busy_answers_to_every_frame_over_rtu() -> None:
    """Every frame meets a busy device once (exception 0x06 is a 5-byte RTU frame): each is
    sent again, nothing is stored twice."""
    image = job_image()
    attempts = [0]

    def busy_once(function_code: int, address: int, _values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and address == FRAME_WINDOW:
            attempts[0] += 1
            return 0x06 if attempts[0] % 2 else None  # the first try of each frame
        return None

    face = device(busy_once)
    run = flash_through("rtu", face, lambda _request: None, image)
    assert run.report.ok, run.report.error
    assert [p.busy_waits for p in run.report.programs] == [len(p.frames) for p in
                                                            image.programs]
    assert downloads(run.report) == [1, 1, 1]
    assert attempts == [2 * sum(len(p.frames) for p in image.programs)]
    assert_settled(face, image, run.report)


def test_busy_answer_to_a_status_read_is_read_again() -> None:
    """A read that meets exception 0x06 was not carried out; it is read again, not reported
    as a refused program."""
    image = job_image()
    busy_reads = [0x06, 0x06]

    def busy(function_code: int, address: int, _values: list[int] | None) -> int | None:
        if function_code == READ_INPUT and address == 100 and busy_reads:
            return busy_reads.pop()
        return None

    face = device(busy)
    run = flash_through("tcp", face, lambda _request: None, image)
    assert run.report.ok, run.report.error
    assert busy_reads == [] and run.link.repeats == 2
    assert_settled(face, image, run.report)


def test_device_that_stays_busy_on_a_line_is_left_ready_and_without_half_a_program() -> None:
    """The flasher gives up on a frame the device keeps refusing as busy (exit 10); the
    download it opened is closed and the slot emptied, so nothing half-written can run."""
    image = job_image()
    line = image.programs[MP41].frames[3]
    face = device(lambda fc, _address, values: 0x06 if fc == WRITE_REGISTERS and values == line
                  else None)
    run = flash_through("tcp", face, lambda _request: None, image,
                        FlashOptions(busy_timeout=0.2))
    assert run.report.outcome == "interrupted" and "stayed busy" in str(run.report.error)
    assert FLASH_EXIT[run.report.outcome] == EXIT_INTERRUPTED
    assert [p.status for p in run.report.programs] == ["verified", "interrupted", "pending"]
    assert_settled(face, image, run.report)
    assert stored(face, "mp", 41) == []


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_link_failures_beyond_the_retries_leave_the_device_ready(transport: str) -> None:
    """Every answer to one frame is lost: after `retries` downloads again the flash stops
    (exit 10). The link still carries other requests, so the open download is closed and
    the slot emptied before the flasher gives up."""
    image = job_image()
    face = device()
    line = image.programs[MP41].frames[3]
    run = flash_through(transport, face, whenever(line, "drop"), image, retries=1)
    assert run.report.outcome == "interrupted" and "gave up after 2 downloads" in \
        str(run.report.error)
    assert FLASH_EXIT[run.report.outcome] == EXIT_INTERRUPTED
    assert run.faults.kinds() == ["drop", "drop"]
    assert_settled(face, image, run.report)
    assert stored(face, "mp", 41) == []


# ------------------------------------------------------------------- refusal of frame k
@pytest.mark.parametrize("frame", range(len(job_image().programs[MP41].frames)))
def test_refusal_of_any_frame_names_its_line_and_leaves_no_half_program(frame: int) -> None:
    """The device refuses frame k of MP41 (SLAVE DEVICE FAILURE, once): the flash stops with
    exit 8 at that frame's source line; MP22 before it is verified, ISR7 after it never sent,
    and MP41 holds nothing that could run."""
    image = job_image()
    target = image.programs[MP41].frames[frame]
    refused: list[int] = []

    def refuse(function_code: int, _address: int, values: list[int] | None) -> int | None:
        pending = face.controller.pending
        in_mp41 = pending is not None and (pending.kind, pending.slot) == ("mp", 41)
        if function_code == WRITE_REGISTERS and values == target and not refused \
                and in_mp41 == (frame > 0):
            refused.append(frame)
            return 0x04
        return None

    face = device(refuse)
    run = flash_through("tcp", face, lambda _request: None, image)
    assert refused == [frame]
    assert run.report.outcome == "rejected" and FLASH_EXIT["rejected"] == EXIT_REJECTED
    assert run.report.where == f"job.mp:{image.programs[MP41].lines[frame]}"
    assert f"refused frame {frame} (" in str(run.report.error)
    assert "SLAVE DEVICE FAILURE" in str(run.report.error)
    assert [p.status for p in run.report.programs] == ["verified", "rejected", "pending"]
    assert_settled(face, image, run.report)
    assert stored(face, "mp", 41) == (None if frame == 0 else [])


def test_a_running_program_makes_the_flash_refuse_before_writing_over_rtu() -> None:
    """Holding register 8 names the running MP: without consent (`stop_running`) nothing
    is opened, nothing written, and the message names the program (not a source line)."""
    image = job_image()
    face = device()
    running = compile_source("MP 1\n    TIMER 100000\nEND MP\n", "running.mp")
    assert face.controller.load_frames("mp", 1, running.programs[0].frames) is None
    face.controller.call(1)  # waits 100 s in its TIMER
    run = flash_through("rtu", face, lambda _request: None, image)
    assert run.report.outcome == "rejected" and run.report.where is None
    assert str(run.report.error).startswith("MP1 is running (holding register 8 reads 1): "
                                            "nothing was written")
    assert [p.status for p in run.report.programs] == ["pending", "pending", "pending"]
    assert not [r for r in run.faults.requests if r.frame is not None]
    assert face.controller.state == "ready" and stored(face, "mp", 22) is None
    assert face.controller.running


# ------------------------------------------------------- a device left in download state
def test_device_left_in_isr_download_state_is_repaired_over_rtu() -> None:
    """An earlier session died inside ISR3's download with a FOR open: the close the flasher
    sends makes the device reject that table (download error), so ISR3 stays empty; the
    flash then goes on and verifies everything."""
    image = job_image()
    face = device()
    vc = face.controller
    assert vc.write_subfunction(vc.encoder.create_frame("isr", 3)) == 0
    assert vc.write_subfunction(image.programs[ISR7].frames[1]) == 0
    assert vc.state == "isr"
    run = flash_through("rtu", face, lambda _request: None, image)
    assert run.report.ok, run.report.error
    assert "the device was in ISR download state" in run.report.notes[0]
    assert "(ISR3)" in run.report.notes[0] and len(run.report.notes) == 2
    assert run.report.notes[1] == "ISR3 held a truncated program: emptied it"
    assert stored(face, "isr", 3) == []
    assert_settled(face, image, run.report)
    assert_runs(face)


def test_device_left_in_download_state_with_an_invalid_table_is_closed() -> None:
    """The stray download holds an unclosed FOR: the device refuses the table at the close
    (download error), so there is nothing to empty."""
    image = job_image()
    face = device()
    vc = face.controller
    assert vc.write_subfunction(vc.encoder.create_frame("mp", 60)) == 0
    assert vc.write_subfunction(image.programs[MP41].frames[3]) == 0  # FOR 3, no NEXT
    run = flash_through("tcp", face, lambda _request: None, image)
    assert run.report.ok, run.report.error
    assert len(run.report.notes) == 1 and "(MP60)" in run.report.notes[0]
    assert stored(face, "mp", 60) is None
    assert_settled(face, image, run.report)


def test_flash_cancelled_mid_program_is_repaired_by_the_next_run() -> None:
    """Ctrl-C in the middle of MP41 leaves its download open (documented); the next run
    closes it and downloads everything, verified."""
    image = job_image()
    face = device()

    async def scenario() -> tuple[str, FlashReport]:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            endpoint = Endpoint(host="127.0.0.1", port=port, timeout=TIMEOUT)
            flasher = Flasher(image, DeviceLink(endpoint))
            task = asyncio.ensure_future(flasher.run())
            deadline = time.monotonic() + 5
            while face.controller.state != "mp" or face.controller.pending is None or \
                    face.controller.pending.slot != 41 or not face.controller.pending.lines:
                assert time.monotonic() < deadline
                await asyncio.sleep(0)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            assert flasher.report.outcome == "interrupted"
            state = face.controller.state
            return state, await Flasher(image, DeviceLink(endpoint)).run()
        finally:
            await stop(server)

    state_after_cancel, report = asyncio.run(scenario())
    assert state_after_cancel == "mp"
    assert report.ok and "(MP41)" in report.notes[0]
    assert_settled(face, image, report)
    assert_runs(face)


# ---------------------------------------------------------------------------- the CLI
async def mpc_flash(source: Path, endpoint: Endpoint, state: Path) -> tuple[int, str]:
    """`mpc flash SOURCE --tcp ...` as a user runs it, while this process serves the device
    (the flash record goes to `state`, not to the user's)."""
    assert endpoint.host is not None
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "mplang", "flash", str(source), "--tcp",
        f"{endpoint.host}:{endpoint.port}", "--timeout", str(endpoint.timeout), "--retries",
        str(endpoint.retries), stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
        cwd=state.parent, env={**os.environ, "XDG_STATE_HOME": str(state)})
    out, err = await asyncio.wait_for(proc.communicate(), 60)
    assert proc.returncode is not None
    text = out.decode() + err.decode()
    assert "Traceback" not in text
    return proc.returncode, err.decode()


@pytest.mark.parametrize(("make_plan", "exit_code", "message"), [
    pytest.param(lambda: at_frame(MP41_FOR, "drop"), EXIT_OK,
                 "downloading it again from its create frame", id="recovered"),
    pytest.param(lambda: whenever(job_image().programs[MP41].frames[3], "drop"),
                 EXIT_INTERRUPTED,
                 "gave up after 2 downloads", id="lost for good"),
])
def test_cli_exit_code_and_device_state_after_a_fault(
        tmp_path: Path, make_plan: Callable[[], Plan], exit_code: int, message: str) -> None:
    """What the user sees: the exit code and the message, and the device is ready either
    way (the record of the flash goes to a temporary state directory)."""
    source = tmp_path / "job.mp"
    source.write_text(JOB)
    plan = make_plan()
    face = device()

    async def scenario() -> tuple[int, str]:
        async with faulty_link("tcp", face, plan, timeout=QUICK, retries=1) \
                as (_injector, endpoint):
            return await mpc_flash(source, endpoint, tmp_path / "state")

    returncode, stderr = asyncio.run(scenario())
    assert returncode == exit_code, stderr
    assert message in stderr
    assert face.controller.state == "ready", f"left in {face.controller.state} download state"
    assert stored(face, "mp", 41) == (job_image().programs[MP41].frames[1:-1]
                                      if exit_code == EXIT_OK else [])
