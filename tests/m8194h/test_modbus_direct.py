"""The virtual M8194H's direct path (`DirectServe`) answers as pymodbus's datastore path does.

Every register request a flash or a status read makes is answered from the register map
directly; anything the direct path leaves alone goes through pymodbus's datastore. Random
request sequences go to two devices alike, one answered by `DirectServe` (falling back to the
datastore where it returns None, as a connection does), the other by the datastore alone: the
answers' bytes, the devices' request and refusal counts and their downloads must agree, and
every request inside the device's register areas must take the direct path. Both sides decode
frames with `QuietDecoder`, which must decode every frame as pymodbus's own decoder does."""

from __future__ import annotations

import asyncio
import struct

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.framer import FramerRTU, FramerSocket
from pymodbus.pdu import DecodePDU, ModbusPDU
from pymodbus.simulator.simcore import SimCore

from mplang.m8194h.modbus import QuietDecoder
from mplang.m8194h.modbus_server import (
    DeviceDecoder,
    DeviceFace,
    DirectServe,
    SimClock,
    malformed,
)
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import INPUT_SPAN, SUBFUNCTION_FIRST

ENCODER = VirtualController().encoder
# the sub-function frames of a download (create MP156, a line, close) and a refused one
FRAMES = [ENCODER.create_frame("mp", 156), [0x0CD2, 0x7FFF, 2, 0, 5],
          ENCODER.close_frame("mp"), [0xFFFF]]
# the edges of the device's areas (holding 0..1323, MD 3000.., 8000..8100, 9008..9015;
# input 0..199) and the registers a flash reads (14, 100..114)
EDGES = [0, 1, 8, 14, 82, 100, 110, 119, 198, 199, 200, 1322, 1323, 1324, 2999, 3000, 3001,
         7094, 7095, 7999, 8000, 8100, 8101, 9007, 9008, 9015, 9016, 65535]
COUNTS = [0, 1, 2, 3, 15, 20, 123, 124, 125, 126, 2000]  # 0, 126+: refused
WORDS = st.lists(st.sampled_from([0, 1, 2, 0x7FFF, 0x8000, 0xFFFF]), min_size=1, max_size=4)


def read(fc: int, address: int, count: int) -> bytes:
    return struct.pack(">BHH", fc, address, count)


def write(address: int, values: list[int]) -> bytes:
    return struct.pack(f">BHHB{len(values)}H", 16, address, len(values), 2 * len(values),
                       *values)


REQUESTS = st.one_of(
    st.builds(read, st.sampled_from([3, 4]), st.sampled_from(EDGES), st.sampled_from(COUNTS)),
    st.builds(write, st.sampled_from(EDGES), WORDS),
    st.builds(write, st.just(SUBFUNCTION_FIRST), st.sampled_from(FRAMES)),
    st.builds(lambda n: write(8, [0] * n), st.sampled_from([123, 124])),  # FC16's limit
)


def still_face() -> DeviceFace:
    """A device whose clock stands still: both devices see the same moment."""
    return DeviceFace(VirtualController(), SimClock(speed=0.0))


def encoded(answer: ModbusPDU) -> bytes:
    return bytes([answer.function_code]) + answer.encode()


def inside(face: DeviceFace, pdu: bytes) -> bool:
    """A well-formed register request inside one of the device's areas."""
    fc, address, count = pdu[0], *struct.unpack(">HH", pdu[1:5])
    spans = [range(0, INPUT_SPAN)] if fc == 4 else face.holding_spans()
    return 1 <= count <= (123 if fc == 16 else 125) and \
        any(address in span and address + count <= span.stop for span in spans)


async def both_ways(requests: list[bytes]) -> None:
    direct_face, store_face = still_face(), still_face()
    direct = DirectServe(direct_face, None)
    cores = {face: SimCore(face.device(0)) for face in (direct_face, store_face)}
    for number, raw in enumerate(requests):
        answers = []
        for face in (direct_face, store_face):
            pdu = DeviceDecoder(face).decode(raw)
            assert pdu is not None
            pdu.dev_id, pdu.transaction_id = 1, number + 1
            answer = direct(pdu) if face is direct_face else None
            if face is direct_face:
                assert (answer is not None) == inside(face, raw), raw.hex()
            if answer is None:
                answer = await pdu.datastore_update(cores[face], pdu.dev_id)
            answers.append(encoded(answer))
        assert answers[0] == answers[1], raw.hex()
    assert direct_face.requests == store_face.requests
    assert [r.code for r in direct_face.refusals] == [r.code for r in store_face.refusals]
    assert direct_face.controller.tables.keys() == store_face.controller.tables.keys()
    for key, table in direct_face.controller.tables.items():
        assert [line.frame for line in table.lines] == \
            [line.frame for line in store_face.controller.tables[key].lines]


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(REQUESTS, min_size=1, max_size=10))
def test_direct_answers_are_the_datastores(requests: list[bytes]) -> None:
    asyncio.run(both_ways(requests))


def test_a_read_of_no_or_too_many_registers_is_refused_as_pymodbus_refuses_it() -> None:
    """FC3 and FC4 read 1 to 125 registers: a request for 0, or for 126 and more (an answer
    of over 250 bytes, more than a byte count can say), is refused by the decoder before the
    direct path sees it, and answered as pymodbus answers it."""
    asyncio.run(both_ways([read(fc, 0, count) for fc in (3, 4) for count in (0, 126, 2000)]))


def test_a_flashs_requests_take_the_direct_path() -> None:
    """The word order (holding 14), the state (input 100..114), and a download."""
    requests = [read(3, 14, 1), read(4, 100, 1), write(SUBFUNCTION_FIRST, FRAMES[0]),
                write(SUBFUNCTION_FIRST, FRAMES[1]), write(SUBFUNCTION_FIRST, FRAMES[2]),
                read(4, 100, 15)]
    asyncio.run(both_ways(requests))
    face = still_face()
    direct = DirectServe(face, 1)
    for raw in requests:
        pdu = DeviceDecoder(face).decode(raw)
        assert pdu is not None
        pdu.dev_id = 1
        assert direct(pdu) is not None
        pdu.dev_id = 2  # another slave on the RTU line: pymodbus's path stays silent
        assert direct(pdu) is None
    assert face.requests == len(requests)
    assert [line.frame for line in face.controller.tables[("mp", 156)].lines] == \
        [tuple(FRAMES[1])]


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.booleans(), st.one_of(
    st.binary(max_size=12),
    st.builds(lambda fc, rest: bytes([fc]) + rest,
              st.sampled_from([1, 2, 3, 4, 5, 6, 8, 15, 16, 23, 43, 0x83, 0x90]),
              st.binary(max_size=12)),
    REQUESTS))
def test_the_quiet_decoder_decodes_as_pymodbus_does(server: bool, frame: bytes) -> None:
    """Requests (server side) and answers (client side), well-formed or not."""
    ours, theirs = QuietDecoder(server).decode(frame), DecodePDU(server).decode(frame)
    assert type(ours) is type(theirs)
    if ours is not None and theirs is not None:  # every field (some do not encode again)
        assert vars(ours) == vars(theirs)


def tcp_frame(tid: int, unit: int, pdu: bytes) -> bytes:
    return FramerSocket(DecodePDU(False)).encode(pdu, unit, tid)


BROKEN = st.one_of(  # whole frames the lean path must leave to the framer (or answer alike)
    st.builds(lambda pdu, cut: pdu[:cut], REQUESTS, st.integers(0, 6)),
    st.builds(lambda pdu, extra: pdu + extra, REQUESTS, st.binary(min_size=1, max_size=3)),
    st.builds(lambda fc, rest: bytes([fc]) + rest, st.sampled_from([1, 5, 6, 8, 15, 43]),
              st.binary(max_size=8)),
)


def lean_takes(face: DeviceFace, pdu: bytes) -> bool:
    """A request the lean path must answer: a well-formed FC3, FC4 or FC16 of exactly its
    length inside the device's areas."""
    return pdu[:1] in (b"\x03", b"\x04", b"\x10") and len(pdu) >= 5 and \
        not malformed(pdu, LIMITS, frozenset()) and (pdu[0] == 16 or len(pdu) == 5) and \
        inside(face, pdu)


async def lean_and_framed(requests: list[tuple[bytes, int]], rtu: bool = False) -> None:
    """Each request (Modbus TCP, or RTU to slave 1) to two devices: one answered by
    `DirectServe.tcp` / `.rtu` (falling back to the decoder, `__call__` and the datastore
    where it returns None, as a connection does), the other by the fallback alone; the
    answers' bytes and the devices must agree."""
    lean_face, framed_face = still_face(), still_face()
    slave = 1 if rtu else None
    direct = DirectServe(lean_face, slave)
    lean = direct.rtu if rtu else direct.tcp
    framer = FramerRTU(DecodePDU(False)) if rtu else FramerSocket(DecodePDU(False))
    for number, (pdu_bytes, unit) in enumerate(requests):
        tid = 0 if rtu else number + 1
        frame = framer.encode(pdu_bytes, unit, tid)
        answers = []
        for face in (lean_face, framed_face):
            if face is lean_face:
                answer = lean(frame)
                if lean_takes(face, pdu_bytes) and unit == (slave or unit):
                    assert answer is not None, frame.hex()
                if answer is not None:
                    answers.append(answer)
                    continue
            pdu = DeviceDecoder(face).decode(pdu_bytes)
            if pdu is None:
                answers.append(b"undecodable")
                continue
            pdu.dev_id, pdu.transaction_id = unit, tid
            reply = DirectServe(face, slave)(pdu)
            if reply is None:
                reply = await pdu.datastore_update(SimCore(face.device(0)), pdu.dev_id)
                reply.dev_id, reply.transaction_id = unit, tid
            answers.append(framer.buildFrame(reply))
        assert answers[0] == answers[1], frame.hex()
    assert lean_face.requests == framed_face.requests
    assert [r.code for r in lean_face.refusals] == [r.code for r in framed_face.refusals]
    for key, table in lean_face.controller.tables.items():
        assert [line.frame for line in table.lines] == \
            [line.frame for line in framed_face.controller.tables[key].lines]


LIMITS = {3: 125, 4: 125, 16: 123}


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.one_of(REQUESTS, BROKEN), st.sampled_from([0, 1, 7, 255])),
                min_size=1, max_size=10), st.booleans())
def test_lean_answers_are_the_framers(requests: list[tuple[bytes, int]], rtu: bool) -> None:
    asyncio.run(lean_and_framed(requests, rtu))


def test_the_lean_path_leaves_a_frame_that_is_not_one_whole_request() -> None:
    """A length field that says more or less than the frame holds, a protocol id other
    than 0, two requests in one read: the framer's to cut, not the lean path's."""
    lean = DirectServe(still_face(), None)
    whole = tcp_frame(1, 1, read(4, 100, 1))
    assert lean.tcp(whole) is not None
    for frame in (whole[:-1], whole + b"\x00", whole + whole,
                  whole[:2] + b"\x00\x01" + whole[4:], whole[:4] + b"\x00\x05" + whole[6:]):
        assert lean.tcp(frame) is None, frame.hex()
    slave = DirectServe(still_face(), 1)
    whole = FramerRTU(DecodePDU(False)).encode(read(4, 100, 1), 1, 0)
    assert slave.rtu(whole) is not None
    for frame in (whole[:-1], whole + whole, whole[:-1] + bytes([whole[-1] ^ 1]),
                  b"\x02" + whole[1:]):  # cut, two, a bad CRC, another slave's
        assert slave.rtu(frame) is None, frame.hex()
