"""Modbus round trips per second against the virtual M8194H (printed, never asserted).

The baseline is a bare pymodbus device with the same blocks and no action hook, served by
the same event loop: the difference is what the register map and the controller cost per
request. The two servers are measured in turns, `ROUNDS` rounds of `REQUESTS` reads each
(the order swapped every round), so that a disturbance of the shared machine falls on both
alike; the figure is the ratio of the medians. No issue sets a target for it: it is
reported against that floor.
"""

from __future__ import annotations

import asyncio
import statistics
import time

from pymodbus.client import AsyncModbusTcpClient
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.m8194h.modbus_server import DeviceFace, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

ROUNDS = 10
REQUESTS = 500  # per round and server: 5,000 reads of each in all


async def round_trips(client: AsyncModbusTcpClient) -> float:
    """Reads of 32 input registers per second, over `REQUESTS` reads."""
    start = time.perf_counter()
    for _ in range(REQUESTS):
        reply = await client.read_input_registers(26, count=32, device_id=1)
        assert not reply.isError()
    return REQUESTS / (time.perf_counter() - start)


async def main() -> None:
    bare = SimDevice(id=0, simdata=([SimData(0, values=[False] * 16, datatype=DataType.BITS)],
                                    [SimData(0, values=[False] * 16, datatype=DataType.BITS)],
                                    [SimData(0, count=1324, datatype=DataType.REGISTERS)],
                                    [SimData(0, count=200, datatype=DataType.REGISTERS)]))
    baseline = ModbusTcpServer(bare, address=("127.0.0.1", 0))
    await baseline.serve_forever(background=True)
    base_port = baseline.transport.sockets[0].getsockname()[1]  # type: ignore[union-attr]
    ours, port = await serve_tcp(DeviceFace(VirtualController()), "127.0.0.1", 0)
    clients = {name: AsyncModbusTcpClient("127.0.0.1", port=p)
               for name, p in (("bare", base_port), ("ours", port))}
    rates: dict[str, list[float]] = {"bare": [], "ours": []}
    try:
        for client in clients.values():
            await client.connect()
        for round_number in range(ROUNDS):
            order = ("bare", "ours") if round_number % 2 == 0 else ("ours", "bare")
            for name in order:
                rates[name].append(await round_trips(clients[name]))
    finally:
        for client in clients.values():
            client.close()
        await stop(ours)
        await baseline.shutdown()  # type: ignore[no-untyped-call]
    bare_rate, our_rate = (statistics.median(rates[name]) for name in ("bare", "ours"))
    spread = max(rates["ours"]) / min(rates["ours"])
    print(f"Modbus TCP reads of 32 input registers: {our_rate:,.0f}/s against the virtual "
          f"M8194H, {bare_rate:,.0f}/s against a bare pymodbus device = "
          f"{our_rate / bare_rate:.2f}x the baseline (medians of {ROUNDS} alternating rounds "
          f"of {REQUESTS:,}; rounds of ours spread {spread:.2f}x; no target set: reported "
          f"against that floor)")


if __name__ == "__main__":
    asyncio.run(main())
