"""The virtual M8194H's Modbus face: every pymodbus name of the server side lives here.

`DeviceFace` puts a `RegisterMap` behind pymodbus's `SimDevice`: four separate blocks
(coils, discrete inputs, holding and input registers) whose `action` hook runs the virtual
controller up to the present moment, then answers from the register map or refuses with the
device's Modbus exception. The controller's simulated clock follows the wall clock (times a
speed factor), so a client sees programs run and axes move in real time. The server decodes
only the function codes the manual documents (`DeviceDecoder`): any other is refused as the
device refuses it, never answered by pymodbus itself (diagnostics, server identification).
Its connections serve every request they receive, in order (`mplang.m8194h.ordered`).

The client (`DeviceLink`) is `mplang.m8194h.modbus`: the commands that only talk to a device
(flash, status, call, var) import that module alone, never this one, the virtual controller,
pymodbus's server or the aiohttp it brings. pymodbus's server modules are imported only when
a server starts, so `mpc run` and the tests that build a face without serving it skip them.
"""

from __future__ import annotations

import asyncio
import gc
import logging
import struct
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeAlias

from pymodbus.constants import ExcCodes
from pymodbus.framer import FramerRTU, FramerType
from pymodbus.pdu import DecodePDU, ExceptionResponse, ModbusPDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadHoldingRegistersResponse,
    ReadInputRegistersRequest,
    ReadInputRegistersResponse,
    WriteMultipleRegistersRequest,
    WriteMultipleRegistersResponse,
)
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.family.linkfail import listen_reason, serial_reason
from mplang.m8194h.modbus import (
    MAX_WRITE_REGISTERS,
    READ_COILS,
    READ_DISCRETE,
    READ_HOLDING,
    READ_INPUT,
    WORDS,
    WRITE_COIL,
    WRITE_COILS,
    WRITE_REGISTER,
    WRITE_REGISTERS,
    QuietDecoder,
    crc16,
)
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
    # (pymodbus.server brings its HTTP simulator and aiohttp)
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
        return self.act(function_code, start_address, address, count, current, values)

    def act(self, function_code: int, start_address: int, address: int, count: int,
            current: list[int], values: list[int] | list[bool] | None) -> ExcCodes | None:
        """One request carried out: `current` (whose first element is register
        `start_address`) gets what a read answers; the exception to answer, or None. Both
        pymodbus's hook and `DirectServe` come here, so a request is served alike on
        either path."""
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

    def holding_spans(self) -> list[range]:
        """The holding register areas the device has; any other address is refused
        ILLEGAL ADDRESS before the request reaches the controller."""
        regs = self.registers
        return [range(0, HOLDING_SPAN), range(regs.md_first, regs.md_end),
                range(SUBFUNCTION_FIRST, SUBFUNCTION_LAST + 1),
                range(SIM_DI_FIRST, SIM_DI_LAST + 1)]

    def device(self, unit: int) -> SimDevice:
        """The pymodbus device: separate coil, discrete input, holding and input blocks."""
        coils = [SimData(0, values=[False] * COIL_SPAN, datatype=DataType.BITS)]
        discrete = [SimData(0, values=[False] * DISCRETE_SPAN, datatype=DataType.BITS)]
        holding = [SimData(span.start, count=len(span), datatype=DataType.REGISTERS)
                   for span in self.holding_spans()]
        inputs = [SimData(0, count=INPUT_SPAN, datatype=DataType.REGISTERS)]
        return SimDevice(id=unit, simdata=(coils, discrete, holding, inputs),
                         action=self.action)


class DirectServe:
    """The register requests of a flash and of a status read (FC3, FC4, FC16), answered
    from the `RegisterMap` directly instead of through pymodbus's datastore, which checks
    every register's flags and awaits three coroutines per request: the same `act`, the
    same answers. Anything else (coils, FC6, a broadcast, another unit, an address outside
    the device's areas, which the datastore refuses before the controller sees it) returns
    None and takes pymodbus's path."""

    def __init__(self, face: DeviceFace, unit: int | None) -> None:
        self.face = face
        self.unit = unit  # RTU: the slave address; None over TCP, which answers every unit
        holding = tuple((span.start, span.stop) for span in face.holding_spans())
        self.spans = {READ_HOLDING: holding, WRITE_REGISTERS: holding,
                      READ_INPUT: ((0, INPUT_SPAN),)}
        # the quantities `DeviceDecoder` lets through (a function code it refuses: none)
        modbus = face.controller.profile.raw["modbus"]
        served = {int(fc) for fc in modbus["function_codes"]}
        self.limits = {int(fc): int(n) for fc, n in modbus["quantity_limits"].items()
                       if int(fc) in served and int(fc) in self.spans}
        if WRITE_REGISTERS in self.limits:
            self.limits[WRITE_REGISTERS] = min(self.limits[WRITE_REGISTERS],
                                               MAX_WRITE_REGISTERS)

    def _inside(self, fc: int, address: int, count: int) -> bool:
        """The request lies inside one of the device's areas for its function code."""
        for start, stop in self.spans[fc]:  # noqa: SIM110  a loop: no generator per request
            if start <= address and address + count <= stop:
                return True
        return False

    def __call__(self, pdu: ModbusPDU) -> ModbusPDU | None:
        """The answer to `pdu`, or None: pymodbus's path serves it."""
        count = pdu.count
        values: list[int] | None = None
        if isinstance(pdu, WriteMultipleRegistersRequest):
            values = list(pdu.registers)
            if not 1 <= count <= MAX_WRITE_REGISTERS or len(values) != count or \
                    pdu.byte_count != 2 * count or \
                    getattr(pdu, "_payload_byte_count", None) != 2 * count:
                return None  # pymodbus's own refusal
        elif isinstance(pdu, (ReadHoldingRegistersRequest, ReadInputRegistersRequest)):
            pass
        else:
            return None
        fc, address = pdu.function_code, pdu.address
        if self.unit is not None and pdu.dev_id != self.unit:
            return None
        if not self._inside(fc, address, count):
            return None
        current = [0] * count if values is None else []
        refused = self.face.act(fc, address, address, count, current, values)
        answer: ModbusPDU
        if refused:
            answer = ExceptionResponse(fc, refused)
        elif values is not None:
            answer = WriteMultipleRegistersResponse(address=address, count=count)
        elif fc == READ_INPUT:
            answer = ReadInputRegistersResponse(registers=current)
        else:
            answer = ReadHoldingRegistersResponse(registers=current)
        answer.dev_id, answer.transaction_id = pdu.dev_id, pdu.transaction_id
        return answer

    def tcp(self, frame: bytes) -> bytes | None:
        """The answer's bytes to `frame`, one whole Modbus TCP request of FC3, FC4 or FC16
        that `DeviceDecoder` and `__call__` would serve here, read and answered without a
        PDU object: the same `act`, the bytes pymodbus's framer makes of the answer (a
        property test compares them). None for anything else (another function code, a
        quantity or byte count the decoder refuses, an address outside the areas, a frame
        that is not exactly one request): pymodbus's framer and `__call__` serve it."""
        if len(frame) < 12 or frame[2] or frame[3] or \
                (frame[4] << 8 | frame[5]) != len(frame) - 6:
            return None
        answer = self._pdu(frame[7:])
        if answer is None:
            return None
        return frame[:4] + (len(answer) + 1).to_bytes(2, "big") + frame[6:7] + answer

    def rtu(self, frame: bytes) -> bytes | None:
        """`tcp` for one whole Modbus RTU request to this slave (unit, PDU, CRC): its
        answer framed as pymodbus's RTU framer frames it, or None (a broadcast, another
        slave's request, a bad CRC, anything `tcp` leaves): pymodbus's path serves it."""
        if len(frame) < 8 or frame[0] != self.unit or crc16(frame[:-2]) != frame[-2:]:
            return None
        answer = self._pdu(frame[1:-2])
        if answer is None:
            return None
        body = frame[:1] + answer
        return body + crc16(body)

    def _pdu(self, pdu: bytes) -> bytes | None:
        """The answer PDU to a request PDU the lean paths serve (see `tcp`), or None."""
        fc = pdu[0]
        limit = self.limits.get(fc)
        if limit is None or len(pdu) < 5:
            return None
        address, count = struct.unpack_from(">HH", pdu, 1)
        if not 1 <= count <= limit or not self._inside(fc, address, count):
            return None
        values: list[int] | None = None
        if fc == WRITE_REGISTERS:
            if len(pdu) != 6 + 2 * count or pdu[5] != 2 * count:
                return None
            values = list(WORDS[count].unpack_from(pdu, 6))
        elif len(pdu) != 5:
            return None
        current = [0] * count if values is None else []
        try:
            refused = self.face.act(fc, address, address, count, current, values)
            if refused:
                return bytes((fc | 0x80, int(refused)))
            if values is not None:  # the FC16 answer: the request's address and count
                return pdu[:5]
            registers: bytes = WORDS[count].pack(*current)
        except Exception:  # the device never falls over: SLAVE DEVICE FAILURE
            return bytes((fc | 0x80, DEVICE_FAILURE))
        return bytes((fc, 2 * count)) + registers


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


class DeviceDecoder(QuietDecoder):
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


_heap_frozen = False


def _freeze_start_up() -> None:
    """In an `mpc` process, the first server to start freezes what start-up made (the
    virtual controllers, the catalogue, the modules) out of the cyclic collector, as the
    first build does (`mplang.lang.heap`): its full passes walked all of it again every few
    thousand requests, 50-75 ms a pass on a 2-core machine for one device, while every
    client waited. Collected first, so no garbage is kept. A program that serves devices as
    a library user (tests, benches) gets the pauses: freezing would keep for good any of its
    objects that later became cyclic garbage."""
    global _heap_frozen
    if _heap_frozen or "mplang.cli" not in sys.modules:
        return
    _heap_frozen = True
    gc.collect()
    gc.freeze()


async def _listen(server: Server, failures: list[BaseException], serial: bool) -> None:
    """Start a server; OpenFailure with the reason if it cannot listen."""
    _freeze_start_up()
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
    direct = DirectServe(face, None)
    serve_in_order(server, direct, direct.tcp)
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
    direct = DirectServe(face, unit)
    serve_in_order(server, direct, direct.rtu)
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
