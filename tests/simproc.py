"""Start `mpc sim` as a subprocess on a free loopback port (shared by the CLI tests)."""

from __future__ import annotations

import subprocess
import sys


def start_sim(*args: str) -> tuple[subprocess.Popen[str], int]:
    """Run `mpc sim --tcp 127.0.0.1:0 ARGS...`; return the process and the port it prints."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                             *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if "Modbus TCP on" in line:
            return proc, int(line.rsplit(":", 1)[1].split()[0])
    proc.wait(10)
    raise AssertionError(f"mpc sim did not start (exit {proc.returncode})")


def start_rtu_sim(*args: str) -> tuple[subprocess.Popen[str], str]:
    """Run `mpc sim --serial pty ARGS...`; return the process and the pty it serves on."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--serial", "pty", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if "Modbus RTU on " in line:
            return proc, line.split("Modbus RTU on ", 1)[1].split()[0]
    proc.wait(10)
    raise AssertionError(f"mpc sim did not start (exit {proc.returncode})")


def raw_holding(device: dict[str, str], address: int, count: int) -> list[int]:
    """Holding registers read by pymodbus used raw, as any other Modbus client would: from
    `{"tcp": "HOST:PORT"}` or `{"serial": PORT}` (115200 8N1, unit 1)."""
    import asyncio

    from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
    from pymodbus.framer import FramerType

    async def read() -> list[int]:
        client: AsyncModbusTcpClient | AsyncModbusSerialClient
        if "tcp" in device:
            host, port = device["tcp"].rsplit(":", 1)
            client = AsyncModbusTcpClient(host, port=int(port), timeout=2)
        else:
            client = AsyncModbusSerialClient(device["serial"], framer=FramerType.RTU,
                                             baudrate=115200, timeout=2)
        await client.connect()
        try:
            reply = await client.read_holding_registers(address, count=count, device_id=1)
            assert not reply.isError(), reply
            return list(reply.registers)
        finally:
            client.close()

    return asyncio.run(read())
