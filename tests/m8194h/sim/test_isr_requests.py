"""Interrupt requests waiting for their ISR stay bounded (9.2.3 ISR execution, 7.3.12 interrupt
factors, 12.1.15 triggered interrupts; profile `limits.isr_queue`, see device-choices.md).

The chip keeps one flag per factor and axis: while an ISR runs its requests wait there, and a
factor that fires again merges; a host's MP_ISR_CALL for an ISR whose call already waits merges
into it. Counted on the model, under floods from the chip and from a raw Modbus client."""

from __future__ import annotations

import asyncio

from pymodbus.client import AsyncModbusTcpClient

from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_tcp, stop
from mplang.m8194h.sim.controller import DeviceBusy, VirtualController
from mplang.m8194h.sim.preload import preload

CAT = catalogue.load()
CAPACITY = CAT.profile.limit("isr_queue")
ISR_CALL = CAT.by_vendor["RSM_MP_ISR_CALL"].code or 0
SERVER_BUSY = 0x06

# ISR1..ISR19 count their runs in VAR1..VAR19; ISR20 runs 40 lines (4 ms at 100 us a line)
LONG_ISR = "\n".join(["ISR 20", *["  VAR20 = VAR20 + 1"] * 40, "END ISR"])
ISRS = "\n".join(f"ISR {n}\n  VAR{n} = VAR{n} + 1\nEND ISR" for n in range(1, 20)) + "\n" + \
    LONG_ISR + "\n"

# PULSE (factor 0) on X calls the long ISR20: 100,000 pulses a second, 400 per ISR run
PULSE_FLOOD = """MP 41
  SET_MAX_V X, 100000
  SET_SV X, 100000
  SET_V X, 100000
  INTFACTOR_ENABLE X, 0, ISR20
  ENABLE_INT
  FIXED_MOVE X, 200000
  STOP_WAIT X
END MP
""" + LONG_ISR + "\n"


def loaded(source: str) -> VirtualController:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController()
    preload(vc, build)
    return vc


def test_7_3_12_a_pulse_interrupt_flood_waits_in_the_chip_flag() -> None:
    vc = loaded(PULSE_FLOOD)
    vc.call(41)
    most = 0
    t = 0.0
    while t < 1.0:
        t = round(t + 0.0005, 6)
        vc.advance(t)
        most = max(most, len(vc.isr_queue) + len(vc.motion.io.requests))
    # one request waits for the running ISR20, however many pulses it runs for
    assert most <= 1
    assert vc.vars[20] >= 40 * 200  # ISR20 ran back to back (4 ms a run) while X moved
    assert vc.motion.lp(1, vc.clock) > 90_000 and vc.error is None


def test_9_2_3_a_flood_of_isr_calls_merges_per_isr() -> None:
    vc = loaded(ISRS)
    vc.write_subfunction([ISR_CALL, 20])
    vc.advance(0.0003)
    assert vc._isr_running()
    most = 0
    sent = 0
    for _round in range(20):
        for n in range(1, 21):
            try:
                vc.write_subfunction([ISR_CALL, n])
                sent += 1
            except DeviceBusy:  # the FIFO is full: the host meets 'busy' (0x06)
                pass
            vc.advance(vc.clock + 0.00005)
            most = max(most, len(vc.isr_queue))
    assert sent > 2 * CAPACITY  # a real flood ...
    assert most <= 20 <= CAPACITY  # ... one waiting call per ISR number at most
    assert any("call merged into the waiting one" in line for line in vc.log)
    vc.advance(vc.clock + 1.0)
    assert not vc.isr_queue and not vc.running
    assert all(1 <= vc.vars[n] < 20 for n in range(1, 20))  # each ran, fewer than called


def test_9_2_3_isr_calls_flooded_over_modbus_tcp_stay_bounded_and_answered() -> None:
    """A raw client writes MP_ISR_CALL frames at 8000 as fast as it can: each is answered OK
    or busy (exception 6, FIFO full), the waiting requests stay within the bound, and every
    ISR called has run once the flood ends."""
    vc = loaded(ISRS)
    face = DeviceFace(vc, SimClock(1.0))

    async def main() -> int:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=2, retries=0)
        most = 0
        try:
            assert await client.connect()
            for _round in range(10):
                for n in (20, *range(1, 21)):
                    reply = await client.write_registers(8000, [ISR_CALL, n], device_id=1)
                    assert not reply.isError() or reply.exception_code == SERVER_BUSY
                    most = max(most, len(vc.isr_queue))
            await asyncio.sleep(0.3)
            state = await client.read_input_registers(100, count=2, device_id=1)
            assert not state.isError()
            return most
        finally:
            client.close()
            await stop(server)

    most = asyncio.run(main())
    assert most <= CAPACITY
    assert not vc.isr_queue and all(vc.vars[n] >= 1 for n in range(1, 21))
