"""Modbus round trips per second against the virtual M8194H (printed, never asserted).

The baseline, measured in the same run, is a bare pymodbus device with the same blocks and
no action hook: the difference is what the register map and the controller cost per request.
"""

from __future__ import annotations

import asyncio
import time

from pymodbus.client import AsyncModbusTcpClient
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.m8194h.modbus import DeviceFace, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

REQUESTS = 400


async def round_trips(port: int) -> float:
    client = AsyncModbusTcpClient("127.0.0.1", port=port)
    await client.connect()
    start = time.perf_counter()
    for _ in range(REQUESTS):
        reply = await client.read_input_registers(26, count=32, device_id=1)
        assert not reply.isError()
    elapsed = time.perf_counter() - start
    client.close()
    return REQUESTS / elapsed


async def main() -> None:
    bare = SimDevice(id=0, simdata=([SimData(0, values=[False] * 16, datatype=DataType.BITS)],
                                    [SimData(0, values=[False] * 16, datatype=DataType.BITS)],
                                    [SimData(0, count=1324, datatype=DataType.REGISTERS)],
                                    [SimData(0, count=200, datatype=DataType.REGISTERS)]))
    server = ModbusTcpServer(bare, address=("127.0.0.1", 0))
    await server.serve_forever(background=True)
    base = await round_trips(server.transport.sockets[0].getsockname()[1])  # type: ignore[union-attr]
    await server.shutdown()  # type: ignore[no-untyped-call]

    controller = VirtualController()
    ours, port = await serve_tcp(DeviceFace(controller), "127.0.0.1", 0)
    rate = await round_trips(port)
    await stop(ours)
    print(f"Modbus TCP reads of 32 input registers: {rate:,.0f}/s against the virtual M8194H, "
          f"{base:,.0f}/s against a bare pymodbus device ({rate / base:.2f}x the baseline)")


if __name__ == "__main__":
    asyncio.run(main())
