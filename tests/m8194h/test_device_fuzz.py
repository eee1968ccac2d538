"""Random frames and request sequences against a served virtual M8194H (issue 13 item 7).

A raw pymodbus client sends what hypothesis draws (sub-function frames, mostly near the
catalogue's shapes, download opens and closes, calls, register reads and writes) over real
loopback TCP and over a pty pair (RTU). After every sequence the device must still answer
(liveness) and keep its invariants: every stored table passes the device's own download
rules, registers 110-114 agree with what is stored, and memory stays bounded. Bounded in
time: few examples, no deadline.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from concurrent.futures import Future
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from mplang.family.ptylink import PtyLink
from mplang.ir import catalogue
from mplang.m8194h.modbus_server import DeviceFace, Server, SimClock, serve_rtu, serve_tcp, stop
from mplang.m8194h.sim import frame_check
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.tables import MacroTable, validate

CAT = catalogue.load()
CODES = sorted(CAT.by_code)
SHAPES = {code: 1 + sum(p.wire for p in command.params) for code, command in CAT.by_code.items()}
VAR_BASE = 0x7FFF


class Served:
    """A virtual controller served in a thread of its own (its own event loop), so that the
    synchronous client of a hypothesis example can talk to it."""

    def __init__(self, transport: str) -> None:
        self.face = DeviceFace(VirtualController(), SimClock(20.0))
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.link: PtyLink | None = None
        self.server: Server
        if transport == "tcp":
            self.server, port = self.run(serve_tcp(self.face, "127.0.0.1", 0))
            self.client: ModbusTcpClient | ModbusSerialClient = ModbusTcpClient(
                "127.0.0.1", port=port, timeout=2, retries=0)
        else:
            self.link = PtyLink()
            self.server = self.run(serve_rtu(self.face, self.link.device_end, unit=1))
            self.client = ModbusSerialClient(self.link.client_end, baudrate=115200, timeout=2,
                                             retries=0)
        assert self.client.connect()

    def run(self, coroutine: Any) -> Any:
        future: Future[Any] = asyncio.run_coroutine_threadsafe(coroutine, self.loop)
        return future.result(10)

    def close(self) -> None:
        self.client.close()
        self.run(stop(self.server))
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)
        if self.link is not None:
            self.link.close()


@pytest.fixture(scope="module", params=["tcp", "rtu"])
def served(request: pytest.FixtureRequest) -> Iterator[Served]:
    device = Served(str(request.param))
    try:
        yield device
    finally:
        device.close()


WORD = st.one_of(st.integers(0, 0xFFFF), st.integers(0, 20), st.just(VAR_BASE),
                 st.sampled_from([0x8000, 0xFFFF, 0x0200, 0x3C, 0x2B]))


@st.composite
def frames(draw: st.DrawFn) -> list[int]:
    """A sub-function frame: mostly a known code with the right length and wild values,
    sometimes a wrong length or an unknown code; download opens and closes are frequent."""
    choice = draw(st.integers(0, 9))
    if choice == 0:
        return [0x0AC9, draw(st.integers(0, 160))]
    if choice == 1:
        return [0x0ACD, draw(st.integers(0, 22))]
    if choice == 2:
        return [draw(st.sampled_from([0x0CCA, 0x0CCE]))]
    if choice == 3:
        return [draw(st.integers(0, 0xFFFF)), *draw(st.lists(WORD, max_size=12))]
    code = draw(st.sampled_from(CODES))
    length = SHAPES[code] if choice < 9 else draw(st.integers(1, 16))
    return [code, *draw(st.lists(WORD, min_size=length - 1, max_size=length - 1))]


STRUCTURE = {"IF", "ELSE", "END_IF", "FOR", "NEXT", "EXIT_FOR", "GOTO", "LABEL", "MP_CLOSE",
             "MP_ISR_CLOSE"}
PLAIN = {kind: sorted(code for code, command in CAT.by_code.items()
                      if kind in command.scope and command.short_name not in STRUCTURE)
         for kind in ("mp", "isr")}
SMALL = st.one_of(st.integers(0, 9), WORD)  # mostly values a parameter takes, often not


@st.composite
def downloads(draw: st.DrawFn) -> list[list[int]]:
    """A whole download: create, a few lines that are mostly in scope and harmless to the
    structure, with values often in range (now and then any frame), usually the close. So
    some downloads succeed, and a value the device should refuse gets a chance to be stored."""
    isr = draw(st.booleans())
    body: list[list[int]] = [[0x0ACD if isr else 0x0AC9, draw(st.integers(1, 20 if isr else 45))]]
    for _ in range(draw(st.integers(0, 5))):
        if draw(st.integers(0, 5)) == 0:
            body.append(draw(frames()))
            continue
        code = draw(st.sampled_from(PLAIN["isr" if isr else "mp"]))
        body.append([code, *draw(st.lists(SMALL, min_size=SHAPES[code] - 1,
                                          max_size=SHAPES[code] - 1))])
    if draw(st.integers(0, 5)):
        body.append([0x0CCE if isr else 0x0CCA])
    return body


REQUESTS = st.one_of(
    st.tuples(st.just("frame"), frames()),
    st.tuples(st.just("download"), downloads()),
    st.tuples(st.just("call"), st.integers(0, 160)),
    st.tuples(st.just("holding"), st.integers(0, 1400), st.lists(WORD, min_size=1, max_size=4)),
    st.tuples(st.just("input"), st.integers(0, 210), st.integers(1, 20)),
)


def send(device: Served, request: tuple[Any, ...]) -> None:
    """One request; any Modbus answer (data or exception) is fine, silence is not."""
    client = device.client
    kind = request[0]
    if kind == "download":
        for frame in request[1]:
            send(device, ("frame", frame))
        return
    if kind == "frame":
        reply = client.write_registers(8000, request[1], device_id=1)
    elif kind == "call":
        reply = client.write_register(8, request[1], device_id=1)
    elif kind == "holding":
        reply = client.write_registers(request[1], request[2], device_id=1)
    else:
        reply = client.read_input_registers(request[1], count=request[2], device_id=1)
    assert reply is not None
    if reply.isError():
        assert getattr(reply, "exception_code", 0) in (1, 2, 3, 4, 6), reply


def check_invariants(device: Served) -> None:
    """Liveness first (the device answers), then what is stored against the rules."""
    reply = device.client.read_input_registers(100, count=20, device_id=1)
    assert not reply.isError(), reply
    state, status = reply.registers[0], reply.registers[10:15]
    vc = device.face.controller
    assert state == {"ready": 0, "mp": 1, "isr": 2}[vc.state]
    for (kind, slot), table in vc.tables.items():
        budget = vc.profile.budget(kind, slot)
        assert budget is not None
        copy = MacroTable(kind, slot, list(table.lines))
        assert validate(copy, budget, CAT, vc.close_counts) is None, (kind, slot)
        for line in table.lines:
            assert frame_check.check(line.command, line.operands, vc.profile) is None
    mp_no, isr_no, _command, _line, error = status
    named = ("mp", mp_no) if mp_no else ("isr", isr_no) if isr_no else None
    if named is not None:
        assert (named in vc.tables) == (error == 0), (status, sorted(vc.tables))
    # memory bounded: the FIFO, the log and an open download stay within the device's sizes
    assert len(vc.fifo) <= vc.fifo_capacity and len(vc.log) <= 200
    if vc.pending is not None:
        table = vc.pending.table
        assert sum(line.command.line_cost for line in table.lines) <= (
            vc.profile.budget(table.kind, table.slot) or 0)


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(sequence=st.lists(REQUESTS, min_size=1, max_size=10))
def test_12_random_requests_never_crash_or_wedge_the_device(
        served: Served, sequence: list[tuple[Any, ...]]) -> None:
    """Appendix 12 (the register map) under random use, over TCP and RTU."""
    for request in sequence:
        send(served, request)
    check_invariants(served)
