"""A pymodbus server connection that serves every request it receives, in order.

pymodbus's `ServerRequestHandler` takes one request per read of its connection and, when it
sends an answer, throws away every byte received and not yet decoded. A request that
arrives in the same read as another one (two frames a relay or gateway passes on together,
a client that does not wait for the previous answer) or while the device is answering is
silently lost. A real M8194H serves each complete frame, in the order of its line or
connection. A lost request is more than a missing answer: when the request before it was
carried out twice (a duplicating relay), the extra answer stands in for the lost request's
own, the client's answer count comes out even, and the device holds one line twice and
misses the next under an answer stream that looks clean.

Imported only where a server starts (`serve_tcp`, `serve_rtu`): it loads pymodbus's server.
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Callable

from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ModbusIOException, NoSuchIdException
from pymodbus.framer import FramerRTU
from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.server.requesthandler import ServerRequestHandler

from mplang.m8194h.modbus import lean_serial

Address = tuple[str, int] | None
Direct = Callable[[ModbusPDU], "ModbusPDU | None"]
"""Answers a request at once, without an await, or returns None when pymodbus's datastore
must serve it (`modbus_server.DirectServe`)."""
Lean = Callable[[bytes], "bytes | None"]
"""Answers one whole request frame's bytes at once with the answer's bytes, or returns None
when the framer and `Direct` must serve it (`modbus_server.DirectServe.tcp`)."""
MAX_QUEUED = 256
"""Requests of one connection decoded and waiting to be served: past it, a client that sends
without reading the answers has further frames dropped, as a device's full receive buffer
drops them, instead of growing the simulator's memory without bound."""


class FramerRTUInOrder(FramerRTU):
    """pymodbus's RTU framer uses up the whole read for its first frame (and the rest of
    the read with a bad CRC): this one uses up the frame only, and a bad CRC skips one byte
    to find the next frame's start."""

    def decode(self, data: bytes) -> tuple[int, int, int, bytes]:
        """(bytes used, unit, 0, PDU), or (bytes used, 0, 0, empty) to wait for more bytes:
        bytes that can no longer start a frame are used up, so line noise is neither kept
        nor scanned again on every read."""
        starts = range(len(data) - self.MIN_SIZE + 1)
        for start in starts:
            kind = self.decoder.lookupPduClass(data[start:])
            if kind is None:
                continue
            size = kind.calculateRtuFrameSize(data[start:])
            if not size or len(data) < start + size:
                return start, 0, 0, self.EMPTY  # wait for the rest of this frame
            end = start + size - 2
            if FramerRTU.check_CRC(data[start:end], int.from_bytes(data[end:end + 2], "big")):
                return start + size, int(data[start]), 0, data[start + 1:end]
        return len(starts), 0, 0, self.EMPTY


class OrderedRequestHandler(ServerRequestHandler):
    """One connection (or serial line) of a server: every complete frame of a read is
    decoded and queued, and one task serves the queue in arrival order; bytes not yet
    decoded are kept when an answer is sent."""

    lean: Lean | None = None  # set by `serve_in_order` where the server traces no PDUs

    def __init__(self, *args: object) -> None:
        super().__init__(*args)  # type: ignore[no-untyped-call]
        self._queue: deque[tuple[ModbusPDU, Address]] = deque()
        self._worker: asyncio.Task[None] | None = None
        self.direct: Direct | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)
        lean_serial(transport)

    def send(self, data: bytes, addr: Address = None) -> None:
        kept = self.recv_buffer  # pymodbus empties it: it may hold the next request
        super().send(data, addr)
        self.recv_buffer = kept

    def callback_data(self, data: bytes, addr: Address = None) -> int:
        """Decode every complete frame in `data` (the packet hook sees `data` once) and
        queue it; returns how many bytes were used."""
        seen = self.trace_packet(False, data)
        if self.lean is not None and seen == data and not self._queue and \
                (self._worker is None or self._worker.done()):
            answer = self.lean(seen)
            if answer is not None:  # pymodbus's `pdu_send` of the same answer
                self.send(self.trace_packet(True, answer))
                return len(data)
        used = 0
        while used < len(seen):
            try:
                cut, pdu = self.framer.handleFrame(seen[used:], 0, 0)
            except ModbusIOException as exc:  # pymodbus's own answer to an undecodable frame
                code = 0x00 if exc.fcode is None else exc.fcode
                refusal = ExceptionResponse(code, exception_code=ExcCodes.ILLEGAL_FUNCTION,
                                            device_id=exc.dev_id, transaction=exc.transaction_id)
                self.server_send(refusal, addr)  # type: ignore[no-untyped-call]
                return len(data)
            used += cut
            if pdu is None:
                break
            pdu = self.trace_pdu(False, pdu)
            busy = self._queue or (self._worker is not None and not self._worker.done())
            if (busy or not self._answer_now(pdu, addr)) and len(self._queue) < MAX_QUEUED:
                self._queue.append((pdu, addr))
        if self._queue and (self._worker is None or self._worker.done()):
            self._worker = asyncio.get_running_loop().create_task(self._serve_queue())
        # a packet hook that changed the bytes (a test's fault) had the whole read
        return used if seen == data else len(data)

    def _answer_now(self, pdu: ModbusPDU, addr: Address) -> bool:
        """Serve `pdu` without a task when `direct` can (nothing waits before it, so the
        order holds); False: it goes through the queue and pymodbus's datastore."""
        if self.direct is None or (self.server.broadcast_enable and not pdu.dev_id):
            return False
        try:
            response = self.direct(pdu)
        except Exception:  # the device never falls over: SLAVE DEVICE FAILURE
            response = ExceptionResponse(pdu.function_code, ExcCodes.DEVICE_FAILURE)
            response.transaction_id, response.dev_id = pdu.transaction_id, pdu.dev_id
        if response is None:
            return False
        self.server_send(response, addr)  # type: ignore[no-untyped-call]
        return True

    async def _serve_queue(self) -> None:
        while self._queue:
            pdu, addr = self._queue.popleft()
            if not self._answer_now(pdu, addr):
                await self._serve(pdu, addr)

    async def _serve(self, pdu: ModbusPDU, addr: Address) -> None:
        """pymodbus's `handle_request` for one queued request (it reads the request from
        the connection's `last_pdu`, which the next read overwrites)."""
        context = self.server.context
        try:
            if self.server.broadcast_enable and not pdu.dev_id:
                for dev_id in context.device_ids():  # a broadcast is not answered
                    await pdu.datastore_update(context, dev_id)
                return
            response = await pdu.datastore_update(context, pdu.dev_id)
        except NoSuchIdException:  # another slave's request: as pymodbus answers it
            if self.server.ignore_missing_devices:
                return
            response = ExceptionResponse(pdu.function_code, ExcCodes.GATEWAY_NO_RESPONSE)
        except Exception:  # the device never falls over: SLAVE DEVICE FAILURE
            response = ExceptionResponse(pdu.function_code, ExcCodes.DEVICE_FAILURE)
        response.transaction_id = pdu.transaction_id
        response.dev_id = pdu.dev_id
        self.server_send(response, addr)  # type: ignore[no-untyped-call]


def serve_in_order(server: object, direct: Direct | None = None,
                   lean: Lean | None = None) -> None:
    """Make `server` (a pymodbus TCP or serial server, not listening yet) hand every new
    connection to an `OrderedRequestHandler`, which answers whole frames through `lean`
    first (not when the server traces PDUs: a lean answer has none), then decoded ones
    through `direct`."""

    def connection() -> OrderedRequestHandler:
        handler = OrderedRequestHandler(
            server, server.trace_packet, server.trace_pdu,  # type: ignore[attr-defined]
            server.trace_connect)  # type: ignore[attr-defined]
        handler.direct = direct
        if server.trace_pdu is None:  # type: ignore[attr-defined]
            handler.lean = lean
        return handler

    server.callback_new_connection = connection  # type: ignore[attr-defined]
    if server.framer is FramerRTU:  # type: ignore[attr-defined]
        server.framer = FramerRTUInOrder  # type: ignore[attr-defined]
