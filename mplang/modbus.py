"""Every pymodbus call of mplang lives here (pymodbus changes its API in minor releases).

The server side puts a `RegisterMap` behind pymodbus's `SimDevice`: four separate blocks
(coils, discrete inputs, holding and input registers) whose `action` hook runs the virtual
controller up to the present moment, then answers from the register map or refuses with the
device's Modbus exception. The controller's simulated clock follows the wall clock (times a
speed factor), so a client sees programs run and axes move in real time.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field

from pymodbus.constants import ExcCodes
from pymodbus.framer import FramerType
from pymodbus.server import ModbusSerialServer, ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.sim.controller import VirtualController
from mplang.sim.registers import (
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

Server = ModbusTcpServer | ModbusSerialServer
"""A running pymodbus server, as `serve_tcp` / `serve_rtu` return it."""

MAX_LINES_PER_CATCH_UP = 200_000
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

    def __init__(self, controller: VirtualController, clock: SimClock | None = None) -> None:
        self.controller = controller
        self.registers = RegisterMap(controller)
        self.clock = clock or SimClock(origin_sim=controller.clock)
        self.requests = 0
        self.refusals: list[Refusal] = []

    def catch_up(self) -> None:
        """Run the controller up to the present moment. A program that needs more lines than
        `MAX_LINES_PER_CATCH_UP` to get there makes the device lag instead of blocking every
        client: its simulated clock falls behind and catches up on later calls."""
        now = self.clock.now()
        if now > self.controller.clock:
            self.controller.advance(now, MAX_LINES_PER_CATCH_UP)

    async def action(self, function_code: int, start_address: int, address: int, count: int,
                     current: list[int], values: list[int] | list[bool] | None) -> ExcCodes | None:
        """pymodbus's hook, called before it answers a request from `current`."""
        self.requests += 1
        self.catch_up()
        try:
            self._serve(function_code, start_address, address, count, current, values)
        except Refusal as refusal:
            self.refusals.append(refusal)
            return ExcCodes(refusal.code)
        return None

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
            raise Refusal(1, reason=f"function code {fc} is not supported")

    def device(self, unit: int) -> SimDevice:
        """The pymodbus device: separate coil, discrete input, holding and input blocks."""
        coils = [SimData(0, values=[False] * COIL_SPAN, datatype=DataType.BITS)]
        discrete = [SimData(0, values=[False] * DISCRETE_SPAN, datatype=DataType.BITS)]
        holding = [
            SimData(0, count=HOLDING_SPAN, datatype=DataType.REGISTERS),
            SimData(SUBFUNCTION_FIRST, count=SUBFUNCTION_LAST - SUBFUNCTION_FIRST + 1,
                    datatype=DataType.REGISTERS),
            SimData(SIM_DI_FIRST, count=SIM_DI_LAST - SIM_DI_FIRST + 1,
                    datatype=DataType.REGISTERS),
        ]
        inputs = [SimData(0, count=INPUT_SPAN, datatype=DataType.REGISTERS)]
        return SimDevice(id=unit, simdata=(coils, discrete, holding, inputs),
                         action=self.action)


class RtuSilence:
    """A real RTU slave does not answer frames addressed to another unit: drop them."""

    def __init__(self, unit: int) -> None:
        self.unit = unit

    def __call__(self, sending: bool, data: bytes) -> bytes:
        if sending and data and data[0] != self.unit:
            return b""
        return data


async def serve_tcp(face: DeviceFace, host: str, port: int) -> tuple[ModbusTcpServer, int]:
    """Listen for Modbus TCP on host:port (port 0: any free port); return the server and the
    port it listens on. Every unit id is answered: the ET-M8194H is the only device there."""
    server = ModbusTcpServer(face.device(0), address=(host, port))
    await server.serve_forever(background=True)
    sockets = getattr(server.transport, "sockets", None) or []
    bound = sockets[0].getsockname()[1] if sockets else port
    return server, int(bound)


async def serve_rtu(face: DeviceFace, port: str, unit: int = 1, baudrate: int = 115200,
                    parity: str = "N", stopbits: int = 1) -> ModbusSerialServer:
    """Answer Modbus RTU as slave `unit` on a serial port (or one end of a pty link)."""
    server = ModbusSerialServer(face.device(unit), framer=FramerType.RTU, port=port,
                                baudrate=baudrate, parity=parity, stopbits=stopbits,
                                bytesize=8, broadcast_enable=True,
                                trace_packet=RtuSilence(unit))
    await server.serve_forever(background=True)
    return server


async def stop(server: Server) -> None:
    await server.shutdown()  # type: ignore[no-untyped-call]
    await asyncio.sleep(0)
