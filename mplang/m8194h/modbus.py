"""The downloader's Modbus client: every pymodbus name of the client side lives here.

`DeviceLink` is the transport of `mplang.m8194h.flash` (and of status, call, var and the
monitor) to one real or virtual device over Modbus TCP or RTU. It raises mplang's own
exceptions (`LinkError` and its kinds, `DeviceException`, defined with `Endpoint` in
`mplang.m8194h.endpoint` and re-exported here) so that the downloader never sees a pymodbus
type.

The virtual device's side is `mplang.m8194h.modbus_server` (and `mplang.m8194h.ordered`):
with this module they are the one adapter of a library that renames its API in minor
releases, so an upgrade is checked in these files. The split keeps the server, the virtual
controller and aiohttp out of the commands that only talk to a device.
"""

from __future__ import annotations

import asyncio
import logging
import os
import struct
import time
from collections.abc import Awaitable, Callable
from typing import Any

from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.framer import FramerRTU, FramerType
from pymodbus.pdu import DecodePDU, ModbusPDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadHoldingRegistersResponse,
    ReadInputRegistersRequest,
    ReadInputRegistersResponse,
)
from pymodbus.transport.serialtransport import SerialTransport
from serial import SerialException  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.family.linkfail import connect_reason, serial_reason
from mplang.m8194h.endpoint import MODBUS_EXCEPTIONS as MODBUS_EXCEPTIONS
from mplang.m8194h.endpoint import DeviceException as DeviceException
from mplang.m8194h.endpoint import Endpoint as Endpoint
from mplang.m8194h.endpoint import LinkError as LinkError
from mplang.m8194h.endpoint import LinkLost as LinkLost
from mplang.m8194h.endpoint import LinkTimeout as LinkTimeout
from mplang.m8194h.endpoint import LinkUnavailable as LinkUnavailable
from mplang.m8194h.endpoint import backoff as backoff
from mplang.m8194h.openfail import recording

READ_COILS, READ_DISCRETE, READ_HOLDING, READ_INPUT = 1, 2, 3, 4
WRITE_COIL, WRITE_REGISTER, WRITE_COILS, WRITE_REGISTERS = 5, 6, 15, 16
SUBFUNCTION_FIRST = 8000  # holding: the sub-function window (appendix table 20; sim.registers too)
PYMODBUS_LOG = logging.getLogger("pymodbus.logging")  # the logger of pymodbus's `Log`


def _expire(future: asyncio.Future[ModbusPDU | None]) -> None:
    """The answer's time is up: the request fails as pymodbus fails one it gave up on."""
    if not future.done():
        future.set_exception(ModbusIOException("no answer in time"))


class QuietDecoder(DecodePDU):
    """pymodbus's PDU decoder without the debug line it formats for every frame even with
    debug logging off (the PDU as text, a few microseconds a frame, on both sides of every
    request). With pymodbus's debug logging on, or for anything but a plain PDU of a
    function code it knows (an exception answer, a sub-function, an unknown or broken
    frame), pymodbus decodes it itself, its log lines and refusals included."""

    def decode(self, frame: bytes) -> ModbusPDU | None:
        if not frame or frame[0] & 0x80 or frame[0] in self.pdu_sub_table or \
                PYMODBUS_LOG.isEnabledFor(logging.DEBUG):
            return super().decode(frame)
        kind = self.pdu_table.get(frame[0], (None, None))[self.pdu_inx]
        if kind is None:
            return super().decode(frame)
        pdu = kind()
        try:
            pdu.decode(frame[1:])
        except Exception:  # pymodbus's own decode says what is wrong with it
            return super().decode(frame)
        return pdu


def lean_serial(transport: object) -> None:
    """Read and write a serial port as a socket transport does: at once. pymodbus's serial
    transport reads through pyserial (two selects and an object per read) and writes on the
    loop's next turn (a writer registered and removed per frame). The bytes, their order,
    and what a lost port does (the transport closes with a SerialException) stay pymodbus's.
    Where pymodbus polls the port (Windows) it is left as it is."""
    if not isinstance(transport, SerialTransport) or transport.force_poll:
        return
    loop, fd = transport.async_loop, transport.sync_serial.fileno()

    def read_ready() -> None:
        try:
            data = os.read(fd, 1024)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            transport.close(exc=SerialException(f"read failed: {exc}"))
            return
        if not data:  # what pyserial says of a port that is ready and reads nothing
            transport.close(exc=SerialException(
                "device reports readiness to read but returned no data (device "
                "disconnected or multiple access on port?)"))
            return
        transport.intern_protocol.data_received(data)  # type: ignore[attr-defined]

    def write(data: bytes) -> None:
        transport.intern_write_buffer.append(data)
        if len(transport.intern_write_buffer) == 1:  # nothing waits for the port: now
            transport.intern_write_ready()
        if transport.intern_write_buffer and transport.sync_serial:  # the rest: when the
            loop.add_writer(fd, transport.intern_write_ready)  # port takes it

    loop.remove_reader(fd)
    loop.add_reader(fd, read_ready)
    transport.write = write  # type: ignore[method-assign]


def crc16(data: bytes) -> bytes:
    """The Modbus RTU CRC of `data` as on the line (low byte first): pymodbus's own, so the
    frames we check and the frames pymodbus writes can never disagree."""
    return FramerRTU.compute_CRC(data).to_bytes(2, "big")


# ------------------------------------------------------------------------------ the link
# The downloader's transport to one device. pymodbus's own repeats are switched off: it would
# send an unanswered FC16 again, and a sub-function frame carried out twice stores a macro line
# twice. So only reads and idempotent holding writes are repeated here; a frame never is, and
# the caller (mplang.m8194h.flash) decides what an unanswered frame means.

MAX_WRITE_REGISTERS = 123  # the Modbus limit for FC16, which pymodbus does not check
DEVICE_BUSY = 0x06  # the exception that says "not carried out, send it again later"
FENCE_REGISTER = 100  # input: a fence reads 2-9 registers from here (ready state onwards)
FENCE_SETTLE_S = 0.002  # after a fence's barrier: events that came with its answer are seen


Client = AsyncModbusTcpClient | AsyncModbusSerialClient
MAX_READ_REGISTERS = 125  # the Modbus limit for FC3 and FC4
WORDS = [struct.Struct(f">{n}H") for n in range(MAX_READ_REGISTERS + 1)]  # register runs
FC16_HEAD = struct.Struct(">BHHB")  # function code, address, count, byte count


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
        self._echo: bytes | None = None  # the answer an FC16 awaits, byte for byte (`_write`)
        self._echo_tid = 0  # its transaction id (TCP)
        self._read_head: bytes | None = None  # the header the answer of a read awaits
        self._read_size = 0  # that answer's length, header, registers and (RTU) CRC
        self._read_kind: type[ModbusPDU] = ReadInputRegistersResponse
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
        tcp = self.endpoint.host is not None
        watch = self._tee if tcp else self._tee_rtu

        def tee(data: bytes) -> None:
            if not self._received and not protocol.recv_buffer:
                reply = self._whole_answer(data, tcp)
                if reply is not False:
                    # the awaited answer, whole, in one read with nothing before it: what
                    # pymodbus's framer would decode it to, counted as `watch` counts it
                    if tcp:
                        self._outstanding.discard(self._echo_tid)
                    elif self._line_outstanding:
                        self._line_outstanding -= 1
                    future = protocol.response_future
                    if not future.done():
                        future.set_result(reply)
                    return
            watch(data)
            received(data)

        protocol.data_received = tee  # type: ignore[method-assign]
        lean_serial(protocol.transport)
        protocol.framer.decoder = QuietDecoder(False)
        self._client, self._lost, self._stale = client, lost, False
        self.opened = True

    def _whole_answer(self, data: bytes, tcp: bool) -> ModbusPDU | bool | None:
        """`data` as the whole answer awaited: None for an FC16's (`_write`), the read's
        answer PDU for a read's (`_round_trip`: its header and length as awaited, over RTU
        its CRC good), or False for anything else, which pymodbus's framer takes."""
        if data == self._echo:
            self._echo = None
            return None
        head = self._read_head
        if head is None or len(data) != self._read_size or not data.startswith(head) or \
                (not tcp and crc16(data[:-2]) != data[-2:]):
            return False
        self._read_head = None
        count = data[len(head) - 1] // 2
        return self._read_kind(registers=list(WORDS[count].unpack_from(data, len(head))),
                               dev_id=self.endpoint.unit, transaction_id=self._echo_tid)

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

    async def _exchange(self, request: Callable[[Client], Awaitable[ModbusPDU | None]],
                        function_code: int, address: int,
                        matches: Callable[[ModbusPDU], bool], fence: bool = True
                        ) -> ModbusPDU | None:
        """One request and its answer, or one of mplang's exceptions. An unsettled link
        fences first. None: the answer was the FC16 echo `_write` awaited, byte for byte."""
        if fence and self._unsettled:
            await self.fence()
        client = await self._ready()
        lost = self._lost
        self._waiting = True  # a lost connection now fails the request at once (`_lost_now`)
        task = asyncio.current_task()
        cancelling = task.cancelling() if task is not None else 0
        try:
            reply = await request(client)
            if task is not None and task.cancelling() > cancelling:
                # a cancel that meets the answer: the caller asked to stop, so stop here
                raise asyncio.CancelledError
        except ConnectionException as exc:
            self._unsettle(lost=True)
            raise LinkLost(f"{self.endpoint.describe()}: connection lost ({exc})") from None
        except ModbusIOException:
            raise self._no_answer(self.endpoint.describe(), lost) from None
        except (ModbusException, OSError) as exc:
            self._unsettle(lost=True)
            raise LinkLost(f"{self.endpoint.describe()}: {exc}") from None
        finally:
            self._waiting = False
        if reply is None:
            return None
        # an exception answer carries the function code (plus 0x80) but no address: a late
        # refusal of another function is told apart by that code alone
        if reply.function_code & 0x7F != function_code or \
                (not reply.isError() and not matches(reply)):
            self._unsettle()
            self.foreign_answers += 1
            raise LinkTimeout(f"{self.endpoint.describe()}: the answer belongs to another "
                              "request")
        if reply.isError():
            raise DeviceException(reply.exception_code, function_code, address)
        return reply

    async def _round_trip(self, client: Client, request: ModbusPDU) -> ModbusPDU:
        """One request and its answer through pymodbus's framer and PDUs, without its
        transaction manager (its lock, `wait_for` and repeat loop cost more CPU than the
        request itself). ModbusIOException: no answer in time."""
        ctx = client.ctx
        if not ctx.transport:
            raise ConnectionException("not connected")
        request.transaction_id = tid = ctx.getNextTID()
        ctx.recv_buffer = b""
        future = self._await_answer(ctx)
        ctx.pdu_send(request)
        fc, count = request.function_code, request.count
        if fc in (READ_HOLDING, READ_INPUT) and 1 <= count <= MAX_READ_REGISTERS:
            # the answer's header, known but for the registers (`_whole_answer`)
            unit = self.endpoint.unit
            self._read_head = struct.pack(">HHHBBB", tid, 0, 3 + 2 * count, unit, fc, 2 * count) \
                if self.endpoint.host is not None else bytes((unit, fc, 2 * count))
            self._read_size = len(self._read_head) + 2 * count + \
                (0 if self.endpoint.host is not None else 2)
            self._read_kind = ReadInputRegistersResponse if fc == READ_INPUT else \
                ReadHoldingRegistersResponse
            self._echo_tid = tid
        reply = await self._answer(ctx, future)
        assert reply is not None  # no echo was awaited
        if (request.dev_id and reply.dev_id != request.dev_id) or \
                (reply.transaction_id and reply.transaction_id != request.transaction_id):
            raise ModbusIOException("the answer names another device or transaction")
        return reply

    @staticmethod
    def _await_answer(ctx: object) -> asyncio.Future[ModbusPDU | None]:
        """The one future the next answer resolves (pymodbus's `response_future`)."""
        future: asyncio.Future[ModbusPDU | None] = asyncio.get_running_loop().create_future()
        ctx.response_future = future  # type: ignore[attr-defined]
        return future

    async def _answer(self, ctx: Any, future: asyncio.Future[ModbusPDU | None]
                      ) -> ModbusPDU | None:
        """Await a request's answer, its timeout by `call_at`. A timeout counts toward
        pymodbus's own rule, kept as it was: after `retries` + 4 unanswered requests in a
        row a TCP connection is closed."""
        loop = future.get_loop()
        timer = loop.call_at(loop.time() + self.endpoint.timeout, _expire, future)
        try:
            reply = await future
        except ModbusIOException:
            if ctx.count_until_disconnect < 0:
                if self.endpoint.host is not None:
                    ctx.connection_lost(TimeoutError("Server not responding"))
            else:
                ctx.count_until_disconnect -= 1
            raise
        finally:
            timer.cancel()
            self._echo = self._read_head = None
        ctx.count_until_disconnect = ctx.max_until_disconnect
        return reply

    async def _write(self, client: Client, address: int, payload: bytes) -> ModbusPDU | None:
        """An FC16 request of the registers packed in `payload`, framed by pymodbus's
        framer from a PDU packed here (the bytes pymodbus's PDU encodes: a property test
        compares them), without building or decoding a PDU object. The answer it awaits is
        known byte for byte: when it arrives whole in one read, the tee resolves the
        request with None; any other answer (an exception, another request's, one cut in
        pieces) takes pymodbus's framer and PDUs, as every answer did before."""
        ctx = client.ctx
        if not ctx.transport:
            raise ConnectionException("not connected")
        unit, count = self.endpoint.unit, len(payload) // 2
        tid = ctx.getNextTID()
        pdu = FC16_HEAD.pack(WRITE_REGISTERS, address, count, len(payload))
        packet = ctx.framer.encode(pdu + payload, unit, tid)
        tcp = self.endpoint.host is not None
        if tcp:
            self._outstanding.add(tid)
        else:
            self._line_outstanding += 1
        ctx.request_dev_id, ctx.request_transaction_id = unit, tid  # as pdu_send sets them
        ctx.recv_buffer = b""
        future = self._await_answer(ctx)
        ctx.transport.write(packet)  # type: ignore[attr-defined]
        # the awaited answer, made while the request is on its way (no answer is read
        # before the next await): MBAP (tid, protocol, length 6, unit) and the request's
        # first five PDU bytes; over RTU the slave, those bytes and their CRC
        self._echo = packet[:4] + b"\x00\x06" + packet[6:12] if tcp else \
            ctx.framer.encode(pdu[:5], unit, tid)
        self._echo_tid = tid
        reply = await self._answer(ctx, future)
        if reply is not None and ((unit and reply.dev_id != unit) or
                                  (reply.transaction_id and reply.transaction_id != tid)):
            raise ModbusIOException("the answer names another device or transaction")
        return reply

    async def _repeating(self, request: Callable[[Client], Awaitable[ModbusPDU | None]],
                         function_code: int, address: int,
                         matches: Callable[[ModbusPDU], bool]) -> ModbusPDU | None:
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
    def _registers(values: list[int] | tuple[int, ...]) -> bytes:
        """The registers of an FC16 write as its PDU carries them (big-endian words)."""
        if not 1 <= len(values) <= MAX_WRITE_REGISTERS:
            raise ValueError(f"an FC16 write takes 1..{MAX_WRITE_REGISTERS} registers, "
                             f"not {len(values)}")
        try:
            return WORDS[len(values)].pack(*values)
        except struct.error:
            registers = [int(v) for v in values]  # a float, a numpy integer: as int() reads it
            if min(registers) < 0 or max(registers) > 0xFFFF:
                raise ValueError("register values are 16-bit: 0..65535") from None
            return WORDS[len(registers)].pack(*registers)

    def _written(self, address: int, payload: bytes
                 ) -> tuple[Callable[[Client], Awaitable[ModbusPDU | None]],
                            Callable[[ModbusPDU], bool]]:
        """An FC16 request of `payload` at `address`, and what its answer must say."""
        count = len(payload) // 2
        return (lambda c: self._write(c, address, payload),
                lambda r: r.address == address and r.count == count)

    async def write_frame(self, frame: list[int] | tuple[int, ...]) -> None:
        """One sub-function frame, FC16 at holding register 8000. Never repeated here: an
        unanswered frame may have been carried out (LinkTimeout / LinkLost say so)."""
        request, matches = self._written(SUBFUNCTION_FIRST, self._registers(frame))
        await self._exchange(request, WRITE_REGISTERS, SUBFUNCTION_FIRST, matches)

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
            kind = ReadInputRegistersRequest if function_code == READ_INPUT else \
                ReadHoldingRegistersRequest
            return self._round_trip(c, kind(address=address, count=count, dev_id=unit))

        return request

    async def _read(self, function_code: int, address: int, count: int) -> list[int]:
        reply = await self._repeating(self._read_request(function_code, address, count),
                                      function_code, address,
                                      lambda r: len(r.registers) == count)
        assert reply is not None  # only an FC16 answer is an echo
        return [int(v) for v in reply.registers[:count]]

    async def write_holding(self, address: int, values: list[int]) -> None:
        """FC16 to holding registers whose write is idempotent (the word order, variables),
        repeated after link failures. Not for register 8 (a call) or the frame window."""
        request, matches = self._written(address, self._registers(values))
        await self._repeating(request, WRITE_REGISTERS, address, matches)

    async def write_once(self, address: int, values: list[int]) -> None:
        """FC16 to holding registers whose write acts (register 8: a call), sent once: an
        unanswered one may have been carried out, so it is never repeated here."""
        request, matches = self._written(address, self._registers(values))
        await self._exchange(request, WRITE_REGISTERS, address, matches)
