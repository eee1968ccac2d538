"""Modbus round trips per second against the virtual M8194H (printed, never asserted).

The baseline is a bare pymodbus device with the same blocks and no action hook, served by
the same event loop: the difference is what the register map and the controller cost per
request. The two servers are measured in turns, `ROUNDS` rounds of `REQUESTS` reads each
(the order swapped every round), so that a disturbance of the shared machine falls on both
alike; the figure is the ratio of the medians. No issue sets a target for it: it is
reported against that floor.

`bench/modbus.py cpu` prints the CPU each side of a flash spends per request (issue 28: "the
client spends 60-83 us of CPU against 20-23 us for a raw socket, and `mpc sim` 50-58 us
against a 22-30 us floor"), each against a raw-socket floor measured in the same run. The
requests are a flash's: one download of `LINES` sub-function frames (FC16 at 8000) a round.
The server under test runs in a child process, so the CPU of each side is its own process's:
- client: `DeviceLink.write_frame` against the raw server, this process's CPU per request,
  beside a raw asyncio client (a future per request, the frames' bytes made beforehand);
- server: the virtual M8194H (`serve_tcp` in a process with the CLI loaded, as `mpc sim`
  serves) driven by the raw client, the child's CPU per request, beside the raw server (it
  echoes each request's first 12 bytes, the FC16 answer) driven alike.
The figures are medians over `CPU_ROUNDS` rounds taken in turns. No target is set for them;
they say which side of a flash a change moved and how far each is from its floor.
"""

from __future__ import annotations

import asyncio
import statistics
import struct
import subprocess
import sys
import time

from pymodbus.client import AsyncModbusTcpClient
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from mplang.m8194h.modbus import DeviceLink, Endpoint
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


# ------------------------------------------------------------------- CPU per request
CPU_ROUNDS = 7
LINES = 500  # line frames per download (a slot holds 512): 502 requests a round
LINE = [0x0CD2, 0x7FFF, 2, 0, 5]  # SET_VAR VAR2, 5: a five-word frame, as most of a flash's


def download_frames() -> list[list[int]]:
    """One round's frames: create MP156, `LINES` lines, close."""
    encoder = VirtualController().encoder
    return [encoder.create_frame("mp", 156), *([LINE] * LINES), encoder.close_frame("mp")]


def tcp_request(tid: int, frame: list[int]) -> bytes:
    """The Modbus TCP bytes of `frame` as an FC16 to holding register 8000, unit 1."""
    body = struct.pack(f">BBHHB{len(frame)}H", 1, 16, 8000, len(frame), 2 * len(frame), *frame)
    return struct.pack(">HHH", tid, 0, len(body)) + body


class RawServer(asyncio.Protocol):
    """The server floor: each request's answer is its first 12 bytes, length 6."""

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        self.transport.write(data[:4] + b"\x00\x06" + data[6:12])  # type: ignore[attr-defined]


class RawClient(asyncio.Protocol):
    """The client floor: one future per request, resolved by the answer's bytes."""

    def __init__(self) -> None:
        self.answer: asyncio.Future[bytes] | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport

    def data_received(self, data: bytes) -> None:
        if self.answer is not None and not self.answer.done():
            self.answer.set_result(data)

    async def ask(self, request: bytes) -> bytes:
        self.answer = asyncio.get_running_loop().create_future()
        self.transport.write(request)  # type: ignore[attr-defined]
        return await self.answer


async def serve_child(kind: str) -> None:
    """The child: serve on a free loopback port and print it; print this process's CPU
    seconds at each line read from stdin; stop at its end."""
    loop = asyncio.get_running_loop()
    if kind == "raw":
        server = await loop.create_server(RawServer, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
    else:  # as `mpc sim` serves: its process has the CLI loaded (which decides, among
        import mplang.cli  # noqa: F401  other things, that its first server freezes the
        # start-up heap out of the cyclic collector, `modbus_server._freeze_start_up`)
        _ours, port = await serve_tcp(DeviceFace(VirtualController()), "127.0.0.1", 0)
    done = loop.create_future()

    def command() -> None:
        if sys.stdin.readline():
            print(time.process_time(), flush=True)
        elif not done.done():
            done.set_result(None)

    loop.add_reader(sys.stdin.fileno(), command)
    print(port, flush=True)
    await done


class Child:
    """A serving child process: its port, and its CPU seconds on request."""

    def __init__(self, kind: str) -> None:
        self.proc = subprocess.Popen([sys.executable, __file__, "serve", kind], text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        assert self.proc.stdout is not None
        self.port = int(self.proc.stdout.readline())

    def cpu(self) -> float:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write("cpu\n")
        self.proc.stdin.flush()
        return float(self.proc.stdout.readline())

    def close(self) -> None:
        self.proc.communicate(timeout=30)


async def raw_round(port: int, frames: list[list[int]]) -> None:
    """One download through the raw client."""
    requests = [tcp_request(tid % 65536, frame) for tid, frame in enumerate(frames, start=1)]
    transport, client = await asyncio.get_running_loop().create_connection(
        RawClient, "127.0.0.1", port)
    try:
        for request in requests:
            answer = await client.ask(request)
            assert answer[7] == 16, answer  # not an exception answer
    finally:
        transport.close()


async def link_round(port: int, frames: list[list[int]]) -> None:
    """One download through `DeviceLink`, as the flasher sends it."""
    async with DeviceLink(Endpoint(host="127.0.0.1", port=port)) as link:
        for frame in frames:
            await link.write_frame(frame)


async def cpu_per_request() -> None:
    frames = download_frames()
    raw, face = Child("raw"), Child("face")
    figures: dict[str, list[float]] = {"client": [], "client floor": [], "server": [],
                                       "server floor": []}
    # (how a round drives, the server it drives, the figures it gives: this process's, the
    # child's); the order turns every round, so a disturbance falls on each alike
    steps = [(link_round, raw, "client", None), (raw_round, raw, "client floor", "server floor"),
             (raw_round, face, None, "server")]
    try:
        for round_number in range(CPU_ROUNDS):
            turn = round_number % len(steps)
            for drive, child, own_figure, child_figure in steps[turn:] + steps[:turn]:
                own, served = time.process_time(), child.cpu()
                await drive(child.port, frames)
                own, served = time.process_time() - own, child.cpu() - served
                if own_figure is not None:
                    figures[own_figure].append(own / len(frames))
                if child_figure is not None:
                    figures[child_figure].append(served / len(frames))
    finally:
        raw.close()
        face.close()
    us = {name: statistics.median(values) * 1e6 for name, values in figures.items()}
    print(f"CPU per request over loopback TCP (FC16 sub-function frames, medians of "
          f"{CPU_ROUNDS} rounds of {len(frames)}; the other side in its own process):")
    for side, what in (("client", "DeviceLink.write_frame"),
                       ("server", "the virtual M8194H (serve_tcp)")):
        floor = us[f"{side} floor"]
        print(f"  {side}: {what} {us[side]:.0f} us against a raw socket's {floor:.0f} us = "
              f"{us[side] / floor:.2f}x the floor")


if __name__ == "__main__":
    if sys.argv[1:2] == ["serve"]:
        asyncio.run(serve_child(sys.argv[2]))
    elif sys.argv[1:] == ["cpu"]:
        asyncio.run(cpu_per_request())
    elif not sys.argv[1:]:
        asyncio.run(main())
        asyncio.run(cpu_per_request())
    else:
        raise SystemExit("usage: bench/modbus.py [cpu]")
