"""Every pymodbus call of mplang lives here (pymodbus changes its API in minor releases).

The server side puts a `RegisterMap` behind pymodbus's `SimDevice`: four separate blocks
(coils, discrete inputs, holding and input registers) whose `action` hook runs the virtual
controller up to the present moment, then answers from the register map or refuses with the
device's Modbus exception. The controller's simulated clock follows the wall clock (times a
speed factor), so a client sees programs run and axes move in real time. The server decodes
only the function codes the manual documents (`DeviceDecoder`): any other is refused as the
device refuses it, never answered by pymodbus itself (diagnostics, server identification).

The client side (`DeviceLink`, below the server) is the downloader's transport to one real
or virtual device over Modbus TCP or RTU. It raises mplang's own exceptions (`LinkError`
and its kinds, `DeviceException`, defined with `Endpoint` in `mplang.m8194h.endpoint` and
re-exported here) so that `mplang.m8194h.flash` never sees a pymodbus type.

Client and server stay in one file because it is the one adapter of a library that renames
its API in minor releases: every pymodbus name mplang uses is here, so an upgrade is checked
in one place. The server's pymodbus modules are imported only when a server starts, so the
commands that only talk to a device (flash, status, call, var) never load them.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeAlias

from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.framer import FramerRTU, FramerType
from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.family.linkfail import connect_reason, listen_reason, serial_reason
from mplang.m8194h.endpoint import MODBUS_EXCEPTIONS as MODBUS_EXCEPTIONS
from mplang.m8194h.endpoint import DeviceException as DeviceException
from mplang.m8194h.endpoint import Endpoint as Endpoint
from mplang.m8194h.endpoint import LinkError as LinkError
from mplang.m8194h.endpoint import LinkLost as LinkLost
from mplang.m8194h.endpoint import LinkTimeout as LinkTimeout
from mplang.m8194h.endpoint import LinkUnavailable as LinkUnavailable
from mplang.m8194h.endpoint import backoff as backoff
from mplang.m8194h.openfail import OpenFailure, recording
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import (
    COIL_SPAN,
    DISCRETE_SPAN,
    HOLDING_SPAN,
    INPUT_SPAN,
    SIM_DI_FIRST,
    SIM_DI_LAST,
    SUBFUNCTION_FIRST,
    SUBFUNCTION_LAST,
    Refusal,
    RegisterMap,
)

if TYPE_CHECKING:  # the servers are imported where one is started, not by every client
    # (pymodbus.server brings its HTTP simulator and aiohttp: most of `mpc flash`'s start-up)
    from pymodbus.server import ModbusSerialServer, ModbusTcpServer

Server: TypeAlias = "ModbusTcpServer | ModbusSerialServer"
"""A running pymodbus server, as `serve_tcp` / `serve_rtu` return it."""
PacketHook = Callable[[bool, bytes], bytes]
"""Sees every Modbus frame a server receives (False) or sends (True) and returns what goes
on: the frame, another one, or b"" to drop it. Tests inject link faults with it."""
Interpose = Callable[[int, int, list[int] | None], int | None]
"""Called with (function code, address, written values or None) before the device serves a
request; a non-zero return refuses it with that Modbus exception code without carrying it
out. Tests make a device busy with it."""

MAX_LINES_PER_CATCH_UP = 200_000
DEVICE_FAILURE = 0x04  # SLAVE DEVICE FAILURE: what a fault inside one request answers
LOG = logging.getLogger("mplang.sim")
# Refusals kept for tests and diagnosis, newest last: a server that keeps every refused request
# (and the frames its traceback holds, about 2 KB each) grows without end under random frames.
REFUSALS_KEPT = 1000
READ_COILS, READ_DISCRETE, READ_HOLDING, READ_INPUT = 1, 2, 3, 4
WRITE_COIL, WRITE_REGISTER, WRITE_COILS, WRITE_REGISTERS = 5, 6, 15, 16


@dataclass
class SimClock:
    """Simulated seconds as a function of wall time: `speed` simulated seconds pass per wall
    second (1.0 = real time; below 1 the device runs in slow motion)."""

    speed: float = 1.0
    origin_wall: float = field(default_factory=time.monotonic)
    origin_sim: float = 0.0

    def now(self) -> float:
        return self.origin_sim + (time.monotonic() - self.origin_wall) * self.speed


def _words(bits: list[bool]) -> list[int]:
    """Bits packed 16 to a register, bit 0 first (the layout of pymodbus's bit blocks)."""
    padded = bits + [False] * (-len(bits) % 16)
    return [sum(1 << k for k in range(16) if padded[16 * w + k]) for w in range(len(padded) // 16)]


class DeviceFace:
    """The Modbus answers of one virtual controller, clocked by a `SimClock`."""

    def __init__(self, controller: VirtualController, clock: SimClock | None = None,
                 interpose: Interpose | None = None) -> None:
        self.controller = controller
        # the FIFO drains at the served pace (profile `execution.served_rtc_command_time_us`)
        execution = controller.profile.raw["execution"]
        controller.rtc_time = int(execution["served_rtc_command_time_us"]) / 1e6
        self.registers = RegisterMap(controller)
        self.clock = clock or SimClock(origin_sim=controller.clock)
        self.interpose = interpose
        self.requests = 0
        self.refused = 0  # every refusal since the start; `refusals` holds the latest only
        self.refusals: deque[Refusal] = deque(maxlen=REFUSALS_KEPT)
        self.persist: Callable[[], bool] | None = None
        """Stores the controller's non-volatile memory (`mpc sim --memory`): called after a
        request that changed it and before that request is answered, as the device's FRAM
        holds a closed download before its status registers say so. False: not stored, and
        the request is answered SLAVE DEVICE FAILURE."""

    def refuse(self, refusal: Refusal) -> ExcCodes:
        """Keep `refusal` without the frames its traceback holds; the exception to answer."""
        self.refused += 1
        self.refusals.append(refusal.with_traceback(None))
        return ExcCodes(refusal.code)

    def catch_up(self) -> None:
        """Run the controller up to the present moment. A program that needs more lines than
        `MAX_LINES_PER_CATCH_UP` to get there makes the device lag instead of blocking every
        client: its simulated clock falls behind and catches up on later calls."""
        now = self.clock.now()
        if now > self.controller.clock:
            try:
                self.controller.advance(now, MAX_LINES_PER_CATCH_UP)
            except Exception as err:  # the device never falls over: see `fault`
                self.controller.fault(err)
                self.controller.clock = max(self.controller.clock, now)

    async def action(self, function_code: int, start_address: int, address: int, count: int,
                     current: list[int], values: list[int] | list[bool] | None) -> ExcCodes | None:
        """pymodbus's hook, called before it answers a request from `current`."""
        self.requests += 1
        version = self.controller.memory_version  # a program's MD writes count too
        self.catch_up()
        if self.interpose is not None:
            written = None if values is None else [int(v) for v in values]
            injected = self.interpose(function_code, address, written)
            if injected:
                return self.refuse(Refusal(injected, reason="injected by interpose"))
        answer: ExcCodes | None = None
        try:
            self._serve(function_code, start_address, address, count, current, values)
        except Refusal as refusal:
            answer = self.refuse(refusal)
        except Exception as err:  # a fault inside one request: SLAVE DEVICE FAILURE
            LOG.warning("internal fault serving FC%d at %d: %r", function_code, address, err,
                        exc_info=err)
            self.controller.log.append(f"{self.controller.clock:.4f} s: internal fault "
                                       f"serving FC{function_code} at {address}: {err!r}")
            answer = self.refuse(Refusal(DEVICE_FAILURE, reason=f"internal fault: {err!r}"))
        if self.persist is not None and self.controller.memory_version != version and \
                not self.persist():  # no await since the change: no reader saw it unsaved
            answer = self.refuse(Refusal(DEVICE_FAILURE, reason="memory file not written"))
        return answer

    def refuse_function(self, function_code: int) -> None:
        """A request whose function code the device does not serve (exception 1 follows)."""
        self.requests += 1
        self.refuse(self.registers.unsupported(function_code))

    def _serve(self, fc: int, start: int, address: int, count: int, current: list[int],
               values: list[int] | list[bool] | None) -> None:
        regs = self.registers
        if fc == READ_INPUT:
            current[address - start:address - start + count] = regs.read_input(address, count)
        elif fc in (WRITE_REGISTER, WRITE_REGISTERS) and values is not None:
            regs.write_holding(address, [int(v) for v in values])
        elif fc in (READ_HOLDING, WRITE_REGISTER, WRITE_REGISTERS):
            # a read, or the read-back pymodbus makes to echo a register write
            current[address - start:address - start + count] = regs.read_holding(address, count)
        elif fc in (WRITE_COIL, WRITE_COILS) and values is not None:
            regs.write_coils(address, [bool(v) for v in values])
        elif fc in (READ_COILS, READ_DISCRETE, WRITE_COIL, WRITE_COILS):
            # a read, or the read-back pymodbus makes to echo a coil write
            # pymodbus passes the bit address and the number of 16-bit words it will read
            coil = fc != READ_DISCRETE
            bits = regs.coils() if coil else regs.discrete_inputs()
            span = COIL_SPAN if coil else DISCRETE_SPAN
            first_word = address // 16
            last_bit = min(span, (first_word + count) * 16)
            if address >= span:
                raise Refusal(2, reason=f"bit {address} is outside the table")
            words = _words(bits[first_word * 16:last_bit])
            current[first_word - start:first_word - start + len(words)] = words
        else:
            raise regs.unsupported(fc)

    def device(self, unit: int) -> SimDevice:
        """The pymodbus device: separate coil, discrete input, holding and input blocks."""
        coils = [SimData(0, values=[False] * COIL_SPAN, datatype=DataType.BITS)]
        discrete = [SimData(0, values=[False] * DISCRETE_SPAN, datatype=DataType.BITS)]
        holding = [
            SimData(0, count=HOLDING_SPAN, datatype=DataType.REGISTERS),
            SimData(self.registers.md_first,
                    count=self.registers.md_end - self.registers.md_first,
                    datatype=DataType.REGISTERS),
            SimData(SUBFUNCTION_FIRST, count=SUBFUNCTION_LAST - SUBFUNCTION_FIRST + 1,
                    datatype=DataType.REGISTERS),
            SimData(SIM_DI_FIRST, count=SIM_DI_LAST - SIM_DI_FIRST + 1,
                    datatype=DataType.REGISTERS),
        ]
        inputs = [SimData(0, count=INPUT_SPAN, datatype=DataType.REGISTERS)]
        return SimDevice(id=unit, simdata=(coils, discrete, holding, inputs),
                         action=self.action)


def crc16(data: bytes) -> bytes:
    """The Modbus RTU CRC of `data` as on the line (low byte first): pymodbus's own, so the
    frames we check and the frames pymodbus writes can never disagree."""
    return FramerRTU.compute_CRC(data).to_bytes(2, "big")


def rtu_frame_size(data: bytes) -> int:
    """The length of the RTU frame at the start of `data` (unit, function, data, CRC) when
    its end can only be found by its CRC: the shortest prefix whose last two bytes are the
    CRC of the rest, or 0 when `data` holds none (yet)."""
    crc = 0xFFFF
    limit = min(len(data), FramerRTU.MAX_SIZE) - 2
    for end, byte in enumerate(data[:limit], start=1):
        crc = ((crc >> 8) & 0xFF) ^ FramerRTU.crc16_table[(crc ^ byte) & 0xFF]
        if end >= 2 and (data[end] | data[end + 1] << 8) == crc:
            return end + 2
    return 0


class RefusedRequest(ModbusPDU):
    """A request the device refuses whatever it holds: its body is not read, the answer is
    the request's function code + 0x80 with `refusal_code`."""

    face: DeviceFace | None = None
    unit: int | None = None  # the RTU slave address; None over TCP, which answers every unit
    refusal_code: int = int(ExcCodes.ILLEGAL_VALUE)
    reason: str = ""

    def decode(self, data: bytes) -> None:
        """Nothing to decode: the function code is all the answer needs."""

    @classmethod
    def calculateRtuFrameSize(cls, data: bytes) -> int:
        return rtu_frame_size(data)

    def note(self, face: DeviceFace) -> None:
        """What the device records of the refusal."""
        face.requests += 1
        face.refuse(Refusal(self.refusal_code, reason=self.reason))

    async def datastore_update(self, context: object, device_id: int) -> ModbusPDU:
        if self.face is not None and self.unit in (None, device_id):  # another slave's
            self.note(self.face)  # request leaves the device's records alone
        return ExceptionResponse(self.function_code, ExcCodes(self.refusal_code))


class UnsupportedRequest(RefusedRequest):
    """A request with a function code the device does not serve: ILLEGAL FUNCTION, and
    register 102 says why."""

    refusal_code = int(ExcCodes.ILLEGAL_FUNCTION)

    def note(self, face: DeviceFace) -> None:
        face.refuse_function(self.function_code)


def malformed(frame: bytes, limits: dict[int, int], coil_values: frozenset[int]) -> str:
    """Why a request PDU of a served function code breaks the Modbus rules the device checks
    (a quantity outside `limits`, a byte count that does not match it, an FC5 value that is
    neither OFF nor ON), or "" for a well-formed one."""
    fc = frame[0]
    if len(frame) < 5:
        return f"FC{fc}: the request is {len(frame)} bytes, too short"
    quantity = int.from_bytes(frame[3:5], "big")
    if fc == WRITE_COIL:
        if quantity in coil_values:
            return ""
        return f"FC5 value 0x{quantity:04X} is neither 0x0000 nor 0xFF00"
    limit = limits.get(fc)
    if limit is not None and not 1 <= quantity <= limit:
        return f"FC{fc}: quantity {quantity} is outside 1..{limit}"
    if fc in (WRITE_COILS, WRITE_REGISTERS):
        expected = (quantity + 7) // 8 if fc == WRITE_COILS else 2 * quantity
        if len(frame) < 6 or frame[5] != expected or len(frame) - 6 != expected:
            return f"FC{fc}: the byte count does not match quantity {quantity}"
    return ""


class DeviceDecoder(DecodePDU):
    """pymodbus's request decoder limited to the function codes of the device profile
    (`[modbus] function_codes`: 1-6, 15, 16). Any other decodes to an `UnsupportedRequest`,
    so FC 7, 8, 11, 17, 43 ... are answered with exception 1 and register 102 = 1 (RS 11366)
    rather than by pymodbus's own diagnostics and identification. A served request that breaks
    the Modbus rules (`malformed`) decodes to a `RefusedRequest`: the request's function code
    + 0x80 and exception 3 (Table 3, RS 939), over TCP and RTU alike."""

    def __init__(self, face: DeviceFace, unit: int | None = None) -> None:
        super().__init__(True)
        self.face = face
        self.unit = unit
        modbus = face.controller.profile.raw["modbus"]
        self.served = frozenset(int(fc) for fc in modbus["function_codes"])
        self.limits = {int(fc): int(n) for fc, n in modbus["quantity_limits"].items()}
        self.coil_values = frozenset(int(v) for v in modbus["coil_values"])
        self.pdu_table = {fc: DecodePDU.pdu_table[fc] for fc in self.served}

    def lookupPduClass(self, data: bytes) -> type[ModbusPDU] | None:
        """RTU framing: an unsupported function code starts a frame only where a complete
        one (valid CRC) is there; otherwise the byte is skipped, as for any garbage."""
        if len(data) > 1 and data[1] not in self.served:
            return UnsupportedRequest if rtu_frame_size(data) else None
        return super().lookupPduClass(data)

    def _refused(self, kind: type[RefusedRequest], function_code: int,
                 reason: str) -> RefusedRequest:
        request = kind()
        request.function_code = function_code
        request.face, request.unit, request.reason = self.face, self.unit, reason
        return request

    def decode(self, frame: bytes) -> ModbusPDU | None:
        if not frame:
            return None
        if frame[0] not in self.served:
            return self._refused(UnsupportedRequest, frame[0], "")
        reason = malformed(frame, self.limits, self.coil_values)
        if reason:
            return self._refused(RefusedRequest, frame[0], reason)
        return super().decode(frame)


class RtuSilence:
    """A real RTU slave does not answer frames addressed to another unit: drop them."""

    def __init__(self, unit: int) -> None:
        self.unit = unit

    def __call__(self, sending: bool, data: bytes) -> bytes:
        if sending and data and data[0] != self.unit:
            return b""
        return data


async def _listen(server: Server, failures: list[BaseException], serial: bool) -> None:
    """Start a server; OpenFailure with the reason if it cannot listen."""
    try:
        await server.serve_forever(background=True)
    except (OSError, RuntimeError) as exc:
        cause = failures[-1] if failures else exc
        raise OpenFailure(serial_reason(cause) if serial else listen_reason(cause)) from None


async def serve_tcp(face: DeviceFace, host: str, port: int,
                    trace_packet: PacketHook | None = None) -> tuple[ModbusTcpServer, int]:
    """Listen for Modbus TCP on host:port (port 0: any free port); return the server and the
    port it listens on. Every unit id is answered: the ET-M8194H is the only device there.
    OpenFailure says why it cannot listen (port in use, no such host, ...)."""
    from pymodbus.server import ModbusTcpServer

    from mplang.m8194h.ordered import serve_in_order

    server = ModbusTcpServer(face.device(0), address=(host, port), trace_packet=trace_packet)
    serve_in_order(server)
    server.decoder = DeviceDecoder(face)  # before any connection: each framer takes it
    face.registers.connections = lambda: len(server.active_connections)
    await _listen(server, recording(server), serial=False)
    sockets = getattr(server.transport, "sockets", None) or []
    bound = sockets[0].getsockname()[1] if sockets else port
    return server, int(bound)


async def serve_rtu(face: DeviceFace, port: str, unit: int = 1, baudrate: int = 115200,
                    parity: str = "N", stopbits: int = 1,
                    trace_packet: PacketHook | None = None) -> ModbusSerialServer:
    """Answer Modbus RTU as slave `unit` on a serial port (or one end of a pty link)."""
    from pymodbus.server import ModbusSerialServer

    from mplang.m8194h.ordered import serve_in_order

    silence = RtuSilence(unit)
    hook: PacketHook = silence
    if trace_packet is not None:
        extra = trace_packet

        def chained(sending: bool, data: bytes) -> bytes:
            data = silence(sending, data)
            return extra(sending, data) if data else data

        hook = chained
    server = ModbusSerialServer(face.device(unit), framer=FramerType.RTU, port=port,
                                baudrate=baudrate, parity=parity, stopbits=stopbits,
                                bytesize=8, broadcast_enable=True, trace_packet=hook)
    serve_in_order(server)
    server.decoder = DeviceDecoder(face, unit)
    await _listen(server, recording(server), serial=True)
    return server


async def stop(server: Server) -> None:
    await server.shutdown()  # type: ignore[no-untyped-call]
    await asyncio.sleep(0)


def drop_connections(server: Server) -> int:
    """Close every client connection of a running server, as a network reset or a device
    reboot does (the server keeps listening). Returns how many were closed."""
    connections = list(server.active_connections.values())
    for connection in connections:
        connection.close()
    return len(connections)


# ================================================================================ client side
# The downloader's transport to one device. pymodbus's own repeats are switched off: it would
# send an unanswered FC16 again, and a sub-function frame carried out twice stores a macro line
# twice. So only reads and idempotent holding writes are repeated here; a frame never is, and
# the caller (mplang.m8194h.flash) decides what an unanswered frame means.

MAX_WRITE_REGISTERS = 123  # the Modbus limit for FC16, which pymodbus does not check
ANSWER_GRACE_S = 1.0  # beyond pymodbus's own timeout, before a request is abandoned here
DEVICE_BUSY = 0x06  # the exception that says "not carried out, send it again later"
FENCE_REGISTER = 100  # input: a fence reads 2-9 registers from here (ready state onwards)
FENCE_SETTLE_S = 0.002  # after a fence's barrier: events that came with its answer are seen


Client = AsyncModbusTcpClient | AsyncModbusSerialClient


class DeviceLink:
    """One connection to one device, one request at a time (the device answers the requests
    of one connection in the order they arrive). A request that gets no answer in time, or
    meets an answer that belongs to another request, leaves the link *unsettled*: the
    request may still reach the device later. Before the next request the link `fence`s:
    it sends a barrier read on the same connection (over RTU: on the same line, in a
    register count nothing else reads) and waits for its answer, which can only come after
    every earlier request on that connection has been carried out or dropped. When no
    barrier gets through (the connection is lost, or stays silent), the link opens a fresh
    connection and reports that only a quiet period, not a barrier, separates the old
    requests from the new ones (`fence` returns False).

    Every answer is counted, also those pymodbus would skip: over TCP by transaction id,
    over RTU against the number of requests sent. An answer beyond them (a duplicated
    request) counts in `anomalies`; over RTU an answer of another request's shape taken
    for the one awaited counts in `foreign_answers`. Either tells the downloader that the
    device carried out something the client did not send at that moment. Usable as
    `async with DeviceLink(endpoint) as link:`."""

    def __init__(self, endpoint: Endpoint) -> None:
        self.endpoint = endpoint
        self._client: Client | None = None
        self._lost = asyncio.Event()
        self._stale = False  # the connection is gone: the next request opens a new one
        self._unsettled = False  # a request may still reach the device: fence first
        self._abandoned_at: float | None = None  # monotonic time of the last abandonment
        self._outstanding: set[int] = set()  # TCP transaction ids sent, not answered
        self._line_outstanding = 0  # RTU requests sent, not answered
        self._received = b""  # TCP bytes received, not yet a whole answer
        self._barriers = 0
        self._waiting = False  # a request awaits its answer
        self.opened = False  # the first connection succeeded
        self.reconnects = 0
        self.repeats = 0  # idempotent requests sent again after a link failure
        self.foreign_answers = 0  # answers of another request's shape, outside a fence
        self.absorbed = 0  # answers of earlier requests a fence met (RTU) before its own
        self.anomalies = 0  # TCP answers to requests already answered (duplicated requests)
        self.fences = 0  # barriers that settled the link
        self.quiet_fences = 0  # fresh connections opened because no barrier got through

    # ------------------------------------------------------------------ connection
    def _make_client(self, lost: asyncio.Event) -> Client:
        ep = self.endpoint
        made: list[Client] = []

        def on_connection(up: bool) -> None:
            if not up:
                lost.set()
                if made:
                    self._lost_now(made[0])

        client: Client
        if ep.host is not None:
            client = AsyncModbusTcpClient(ep.host, port=ep.port, timeout=ep.timeout, retries=0,
                                          reconnect_delay=0, trace_connect=on_connection,
                                          trace_packet=self._sending)
        else:
            assert ep.serial is not None
            client = AsyncModbusSerialClient(
                ep.serial, framer=FramerType.RTU, baudrate=ep.baudrate, bytesize=8,
                parity=ep.parity, stopbits=ep.stopbits, timeout=ep.timeout, retries=0,
                reconnect_delay=0, trace_connect=on_connection, trace_packet=self._sending)
        made.append(client)
        return client

    def _lost_now(self, client: Client) -> None:
        """The connection closed: the request waiting for its answer (if any) fails now
        with ConnectionException instead of waiting out its timeout. The request is awaited
        directly (one await, no watcher task), so the answer's future is where to say it."""
        future = getattr(client.ctx, "response_future", None)
        if self._waiting and future is not None and not future.done():
            future.set_exception(ConnectionException("connection lost"))

    def _sending(self, sending: bool, packet: bytes) -> bytes:
        """pymodbus's packet hook: note every request sent (TCP: its transaction id)."""
        if sending and self.endpoint.host is None:
            self._line_outstanding += 1
        elif sending and len(packet) >= 2:
            self._outstanding.add(int.from_bytes(packet[:2], "big"))
        return packet

    def _tee_rtu(self, data: bytes) -> None:
        """Every byte the RTU port receives, before pymodbus sees it: pymodbus ignores an
        answer that arrives while no request waits, so only here does an answer beyond the
        requests sent (the device carried one out twice) become visible. Answers are cut
        by their function code and length and count only with a good CRC."""
        self._received += data
        while len(self._received) >= 5:
            buf = self._received
            fc = buf[1]
            size = 5 if fc & 0x80 else 8 if fc in (5, 6, 15, 16) else \
                5 + buf[2] if fc in (1, 2, 3, 4) else 0
            if size and len(buf) < size:
                return
            if not size or crc16(buf[:size - 2]) != buf[size - 2:size]:
                self._received = buf[1:]  # not an answer's start: resynchronise
                continue
            self._received = buf[size:]
            if self._line_outstanding:
                self._line_outstanding -= 1
            else:
                self.anomalies += 1

    def _tee(self, data: bytes) -> None:
        """Every byte the TCP connection receives, before pymodbus sees it: pymodbus skips
        an answer whose transaction id it is not waiting for, so only here does an answer
        to a request answered already (the device carried it out twice) become visible."""
        self._received += data
        while len(self._received) >= 6:
            size = 6 + int.from_bytes(self._received[4:6], "big")
            if len(self._received) < size:
                return
            tid = int.from_bytes(self._received[:2], "big")
            self._received = self._received[size:]
            if tid in self._outstanding:
                self._outstanding.discard(tid)
            else:
                self.anomalies += 1

    async def open(self) -> None:
        """Connect (TCP) or open the port (RTU); raise LinkUnavailable if that fails."""
        self.close()
        lost = asyncio.Event()
        client = self._make_client(lost)
        self._outstanding, self._received, self._line_outstanding = set(), b"", 0
        failures = recording(client.ctx)
        try:
            connected = await client.connect()
        except (OSError, ModbusException, ValueError) as exc:
            failures.append(exc)
            connected = False
        if not connected:
            client.close()
            raise LinkUnavailable(self._unavailable(failures[-1] if failures else None))
        protocol = client.ctx
        received = protocol.data_received
        watch = self._tee if self.endpoint.host is not None else self._tee_rtu

        def tee(data: bytes) -> None:
            watch(data)
            received(data)

        protocol.data_received = tee  # type: ignore[method-assign]
        self._client, self._lost, self._stale = client, lost, False
        self.opened = True

    def _unavailable(self, exc: BaseException | None) -> str:
        """The one-line reason a connection or port could not be opened."""
        ep = self.endpoint
        if ep.host is not None:
            return f"cannot connect to {ep.host}:{ep.port} (Modbus TCP): {connect_reason(exc)}"
        return (f"cannot open serial port {ep.serial} (Modbus RTU, {ep.baudrate} "
                f"8{ep.parity}{ep.stopbits}): {serial_reason(exc)}")

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    async def __aenter__(self) -> DeviceLink:
        await self.open()
        return self

    async def __aexit__(self, *_exc: object) -> None:
        self.close()

    def _usable(self) -> bool:
        client = self._client
        return client is not None and client.connected and not self._stale \
            and not self._lost.is_set()

    async def _ready(self) -> Client:
        """The live client; reconnects first (with growing pauses, up to `retries` times)
        after a lost connection."""
        if self._usable():
            assert self._client is not None
            return self._client
        await self._quiet()
        if not self.opened:
            await self.open()
        else:
            attempt = 0
            while True:
                self.reconnects += 1
                try:
                    await self.open()
                    break
                except LinkUnavailable:
                    attempt += 1
                    if attempt > self.endpoint.retries:
                        raise
                    await asyncio.sleep(backoff(attempt, self.endpoint.timeout))
        assert self._client is not None
        return self._client

    def _unsettle(self, lost: bool = False) -> None:
        """A request went unanswered (or its connection broke): it may still reach the
        device, so the next request fences first. A lost connection is closed at once."""
        self._unsettled = True
        self._abandoned_at = time.monotonic()
        if lost:
            self._stale = True
            self.close()

    async def _quiet(self) -> None:
        """Over RTU, keep the port closed until one `timeout` has passed since the last
        abandoned request: a device that answers late answers into the closed port."""
        if self.endpoint.serial is None or self._abandoned_at is None:
            return
        remaining = self._abandoned_at + self.endpoint.timeout - time.monotonic()
        self._abandoned_at = None
        if remaining > 0:
            await asyncio.sleep(remaining)

    @property
    def settled(self) -> bool:
        """No request sent on this link can still reach the device unseen."""
        return not self._unsettled

    async def fence(self) -> bool:
        """Make sure nothing sent earlier can still reach the device after this returns.
        True: a barrier read on the same connection was answered, so every earlier request
        was carried out (or dropped) before it. False: no barrier got through, a fresh
        connection is open and only time separates the old requests from the new ones;
        the caller verifies a quiet period before it relies on the device's state."""
        if not self._unsettled:
            return True
        foreign = self.foreign_answers
        try:
            return await self._fence()
        finally:  # late answers a fence meets are the abandoned requests' own: expected
            self.absorbed += self.foreign_answers - foreign
            self.foreign_answers = foreign

    async def _fence(self) -> bool:
        for _attempt in range(self.endpoint.retries + 2):
            if not self._usable():
                break
            self._unsettled = False
            self._barriers += 1
            count = 2 + self._barriers % 8  # a shape no other request of the flash has

            def barrier(reply: ModbusPDU, count: int = count) -> bool:
                return len(reply.registers) == count

            try:
                await self._exchange(self._read_request(READ_INPUT, FENCE_REGISTER, count),
                                     READ_INPUT, FENCE_REGISTER, barrier, fence=False)
            except (LinkTimeout, LinkLost):
                continue
            except DeviceException:
                pass  # a refusal is still the barrier's answer
            self.fences += 1
            self._outstanding.clear()
            self._line_outstanding = 0
            self._received = b""  # what remains is no answer (a corrupted one's rest)
            # a late answer often comes with the close of the connection that held it (a
            # gateway or proxy giving up on it): let the loop see that close before the next
            # request is sent, so that request goes out on a fresh connection
            await asyncio.sleep(FENCE_SETTLE_S)
            return True
        self._unsettled = False
        self._stale = True
        self.close()
        await self._ready()
        self.quiet_fences += 1
        return False

    # -------------------------------------------------------------------- requests
    def _no_answer(self, describe: str, lost: asyncio.Event) -> LinkError:
        """No answer came: the connection was lost on the way, or the device kept quiet."""
        if lost.is_set():
            self._unsettle(lost=True)
            return LinkLost(f"{describe}: connection lost")
        self._unsettle()
        return LinkTimeout(f"{describe}: no answer within {self.endpoint.timeout:g} s")

    async def _exchange(self, request: Callable[[Client], Awaitable[ModbusPDU]],
                        function_code: int, address: int,
                        matches: Callable[[ModbusPDU], bool], fence: bool = True
                        ) -> ModbusPDU:
        """One request and its answer, or one of mplang's exceptions. An unsettled link
        fences first."""
        if fence and self._unsettled:
            await self.fence()
        client = await self._ready()
        lost = self._lost
        describe = self.endpoint.describe()
        self._waiting = True  # a lost connection now fails the request at once (`_lost_now`)
        guard = asyncio.timeout(self.endpoint.timeout + ANSWER_GRACE_S)
        task = asyncio.current_task()
        cancelling = task.cancelling() if task is not None else 0
        try:
            async with guard:
                reply = await request(client)
            if task is not None and task.cancelling() > cancelling:
                # pymodbus's wait_for (Python 3.11) drops a cancel that meets the answer:
                # the caller asked to stop, so stop here as it would have
                raise asyncio.CancelledError
        except TimeoutError as exc:
            if not guard.expired():  # a socket timeout inside pymodbus: the link failed
                self._unsettle(lost=True)
                raise LinkLost(f"{describe}: {exc}") from None
            raise self._no_answer(describe, lost) from None
        except ConnectionException as exc:
            self._unsettle(lost=True)
            raise LinkLost(f"{describe}: connection lost ({exc})") from None
        except ModbusIOException:
            raise self._no_answer(describe, lost) from None
        except (ModbusException, OSError) as exc:
            self._unsettle(lost=True)
            raise LinkLost(f"{describe}: {exc}") from None
        finally:
            self._waiting = False
        # an exception answer carries the function code (plus 0x80) but no address: a late
        # refusal of another function is told apart by that code alone
        if reply.function_code & 0x7F != function_code or \
                (not reply.isError() and not matches(reply)):
            self._unsettle()
            self.foreign_answers += 1
            raise LinkTimeout(f"{describe}: the answer belongs to another request")
        if reply.isError():
            raise DeviceException(reply.exception_code, function_code, address)
        return reply

    async def _repeating(self, request: Callable[[Client], Awaitable[ModbusPDU]],
                         function_code: int, address: int,
                         matches: Callable[[ModbusPDU], bool]) -> ModbusPDU:
        """`_exchange`, repeated after a timeout, a lost link or a busy answer (exception
        0x06: not carried out): only for requests that do the same thing however often they
        arrive."""
        attempt = 0
        while True:
            try:
                return await self._exchange(request, function_code, address, matches)
            except (LinkTimeout, LinkLost, DeviceException) as exc:
                if isinstance(exc, DeviceException) and exc.code != DEVICE_BUSY:
                    raise
                attempt += 1
                if attempt > self.endpoint.retries:
                    raise
                self.repeats += 1
                await asyncio.sleep(backoff(attempt, self.endpoint.timeout))

    @staticmethod
    def _registers(values: list[int] | tuple[int, ...]) -> list[int]:
        if not 1 <= len(values) <= MAX_WRITE_REGISTERS:
            raise ValueError(f"an FC16 write takes 1..{MAX_WRITE_REGISTERS} registers, "
                             f"not {len(values)}")
        if any(not 0 <= int(v) <= 0xFFFF for v in values):
            raise ValueError("register values are 16-bit: 0..65535")
        return [int(v) for v in values]

    async def write_frame(self, frame: list[int] | tuple[int, ...]) -> None:
        """One sub-function frame, FC16 at holding register 8000. Never repeated here: an
        unanswered frame may have been carried out (LinkTimeout / LinkLost say so)."""
        values = self._registers(frame)
        unit = self.endpoint.unit
        await self._exchange(
            lambda c: c.write_registers(SUBFUNCTION_FIRST, values, device_id=unit),
            WRITE_REGISTERS, SUBFUNCTION_FIRST,
            lambda r: r.address == SUBFUNCTION_FIRST and r.count == len(values))

    async def read_input(self, address: int, count: int) -> list[int]:
        """FC4: `count` input registers from `address` (repeated after link failures)."""
        return await self._read(READ_INPUT, address, count)

    async def read_holding(self, address: int, count: int) -> list[int]:
        """FC3: `count` holding registers from `address` (repeated after link failures)."""
        return await self._read(READ_HOLDING, address, count)

    def _read_request(self, function_code: int, address: int, count: int
                      ) -> Callable[[Client], Awaitable[ModbusPDU]]:
        unit = self.endpoint.unit

        def request(c: Client) -> Awaitable[ModbusPDU]:
            read = c.read_input_registers if function_code == READ_INPUT else \
                c.read_holding_registers
            return read(address, count=count, device_id=unit)

        return request

    async def _read(self, function_code: int, address: int, count: int) -> list[int]:
        reply = await self._repeating(self._read_request(function_code, address, count),
                                      function_code, address,
                                      lambda r: len(r.registers) == count)
        return [int(v) for v in reply.registers[:count]]

    async def write_holding(self, address: int, values: list[int]) -> None:
        """FC16 to holding registers whose write is idempotent (the word order, variables),
        repeated after link failures. Not for register 8 (a call) or the frame window."""
        registers = self._registers(values)
        unit = self.endpoint.unit
        await self._repeating(
            lambda c: c.write_registers(address, registers, device_id=unit),
            WRITE_REGISTERS, address,
            lambda r: r.address == address and r.count == len(registers))

    async def write_once(self, address: int, values: list[int]) -> None:
        """FC16 to holding registers whose write acts (register 8: a call), sent once: an
        unanswered one may have been carried out, so it is never repeated here."""
        registers = self._registers(values)
        unit = self.endpoint.unit
        await self._exchange(
            lambda c: c.write_registers(address, registers, device_id=unit),
            WRITE_REGISTERS, address,
            lambda r: r.address == address and r.count == len(registers))
