"""Axis input lamps of `mpc status`: each axis's DI status word, input registers 16-19
(RS-M8194H manual appendix 12.1.2, table 2), decoded with the bit order of RSM_GET_DI_ALL
(RS 3349) and the polarities of appendix table 25 (discrete inputs 128 + 16 x axis,
RS 12136-12185), as the device profile's [lamps] lists them. The virtual controller is
served over real loopback Modbus TCP with a machine where some inputs are on, and read as
`mpc status` reads it; the same bits are read back as table 25's discrete inputs (FC2)."""

from __future__ import annotations

import asyncio

from pymodbus.client import AsyncModbusTcpClient

from mplang.ir import catalogue
from mplang.m8194h.modbus import Endpoint
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_tcp, stop
from mplang.m8194h.sim.axis_io import AxisSensors
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.status import lamp_bits, probe, render

NOTHING = {"near_home": None, "home": None, "index_period": None}


def machine() -> VirtualController:
    """X on its LIMIT+ switch; Y on LIMIT- and near home; Z at home with an enabled alarm
    raised; U with its servo on (INPOS, RS 12149: an ideal drive is in position at rest)."""
    vc = VirtualController()
    io = vc.motion.io
    io.set_sensors(0, AxisSensors(limit_plus=0, **NOTHING), 0.0)  # type: ignore[arg-type]
    io.set_sensors(1, AxisSensors(limit_minus=5, near_home=(-10, 10), home=None,
                                  index_period=None), 0.0)
    io.set_sensors(2, AxisSensors(home=(-1, 1), near_home=None, index_period=None), 0.0)
    io.set_alarm(4, 1, 0, 0.0)
    io.set_alarm_input(2, True, 0.0)
    io.set_sensors(3, AxisSensors(**NOTHING), 0.0)  # type: ignore[arg-type]
    io.servo(8, True)
    return vc


def on(axis: dict[str, object]) -> set[str]:
    lamps = axis["lamps"]
    assert isinstance(lamps, dict)
    return {name for name, lit in lamps.items() if lit}


def test_appendix_12_1_2_lamps_read_over_modbus_tcp_agree_with_table_25() -> None:
    async def scenario() -> None:
        vc = machine()
        face = DeviceFace(vc, SimClock(1.0, origin_sim=vc.clock))
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        try:
            data = await probe(Endpoint(host="127.0.0.1", port=port), None,
                               lambda _order: (None, []))
            assert isinstance(data, dict), data
            axes = data["axes"]
            assert on(axes[0]) == {"limit_plus"}
            assert on(axes[1]) == {"limit_minus", "near_home"}
            assert on(axes[2]) == {"home", "alarm"}
            assert on(axes[3]) == {"inpos"}
            text = render(data)
            assert "  X  LP" in text and text.split("  X  LP", 1)[1].split("\n")[0] \
                .endswith("stopped  L+")
            assert text.split("  Z  LP", 1)[1].split("\n")[0].endswith("HM AL")

            vc.motion.io.set_emg_input(True, face.clock.now())  # the EMG input: every axis
            emergency = await probe(Endpoint(host="127.0.0.1", port=port), None,
                                    lambda _order: (None, []))
            assert isinstance(emergency, dict)
            assert all("emg" in on(axis) for axis in emergency["axes"])

            assert await client.connect()  # table 25: the same bits as discrete inputs
            bits = lamp_bits(catalogue.load())
            for n, axis in enumerate(emergency["axes"]):
                reply = await client.read_discrete_inputs(128 + 16 * n, count=16, device_id=1)
                for name, (bit, value) in bits.items():
                    assert (reply.bits[bit] == bool(value)) == axis["lamps"][name], (n, name)
        finally:
            client.close()
            await stop(server)

    asyncio.run(scenario())


def test_rs_3349_lamp_bits_of_the_profile_follow_get_di_all() -> None:
    """RSM_GET_DI_ALL: bit 0 DRIVING, 1 LIMIT+, 2 LIMIT-, 3 EMERGENCY, 4 ALARM, 5 IN1 (home),
    6 IN0 (near home), 7 IN3, 8 INPOS, 9 IN2 (index); table 25: the inputs read 0 when on."""
    bits = lamp_bits(catalogue.load())
    assert bits == {"driving": (0, 1), "limit_plus": (1, 1), "limit_minus": (2, 1),
                    "emg": (3, 1), "alarm": (4, 1), "home": (5, 0), "near_home": (6, 0),
                    "in3": (7, 0), "inpos": (8, 0), "index": (9, 0)}
