"""`mpc sim --devices N` (issue 16): N virtual M8194H from one process on consecutive Modbus TCP
ports, each with its own macro memory file, flashed as a fleet by `mpc flash --fleet` and read
by a real client (`DeviceLink`, Modbus TCP over loopback)."""

from __future__ import annotations

import asyncio
import json
import random
import signal
import socket
import subprocess
import sys
from pathlib import Path

from mplang.cli import EXIT_OK, EXIT_USAGE
from mplang.m8194h.modbus import DeviceLink, Endpoint

JOB = """MP 3 first
    SET_V X, 1000
    FIXED_MOVE X, 100
END MP
MP 4 second
    VAR1 = VAR1 + 1
END MP
"""
OTHER = """MP 7 third
    VAR2 = 5
END MP
"""
WORD_ORDER_REGISTER = 14  # holding register: the device's word order (0 or 1)


def free_ports(count: int) -> int:
    """The first of `count` consecutive loopback ports nobody listens on (probed), from a
    random start: two tests probing from the same port at once would pick the same ones."""
    start = random.randrange(21_000, 50_000)
    for base in [*range(start, 60_000, count + 7), *range(21_000, start, count + 7)]:
        probes = [socket.socket() for _ in range(count)]
        try:
            for offset, probe in enumerate(probes):
                probe.bind(("127.0.0.1", base + offset))
            return base
        except OSError:
            continue
        finally:
            for probe in probes:
                probe.close()
    raise AssertionError("no free ports")


def start_devices(count: int, memory: Path, *args: str
                  ) -> tuple[subprocess.Popen[str], list[int], str]:
    """`mpc sim --devices COUNT` from a free port; the process, its ports, what it said.
    Ports probed free can be taken before mpc sim binds them (another test, another
    process): then it is started again on other ports."""
    for _attempt in range(4):
        try:
            return _start_devices_once(count, memory, *args)
        except PortTaken:
            continue
    return _start_devices_once(count, memory, *args)


class PortTaken(AssertionError):
    """mpc sim could not listen: a probed port was taken in the meantime."""


def _start_devices_once(count: int, memory: Path, *args: str
                        ) -> tuple[subprocess.Popen[str], list[int], str]:
    first = free_ports(count)
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--tcp",
                             f"127.0.0.1:{first}", "--devices", str(count), "--memory",
                             str(memory), "--speed", "10", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    ports: list[int] = []
    lines: list[str] = []
    for line in proc.stdout:
        lines.append(line)
        if "Modbus TCP on" in line:
            ports.append(int(line.rsplit(":", 1)[1].split()[0]))
            if len(ports) == count:
                return proc, ports, "".join(lines)
    proc.wait(10)
    said = "".join(lines)
    if "port already in use" in said:
        raise PortTaken(said)
    raise AssertionError(f"mpc sim did not start (exit {proc.returncode}): {said}")


def stop_devices(proc: subprocess.Popen[str]) -> str:
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=30)
    return out


def mpc(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


async def word_orders(ports: list[int]) -> list[int]:
    """Holding register 14 of every device, each read by its own client connection."""
    values = []
    for port in ports:
        async with DeviceLink(Endpoint(host="127.0.0.1", port=port, timeout=2.0)) as link:
            values += await link.read_holding(WORD_ORDER_REGISTER, 1)
    return values


def test_three_devices_on_consecutive_ports_flashed_as_a_fleet_keep_their_own_memory(
        tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text(JOB)
    (tmp_path / "other.mp").write_text(OTHER)
    memory = tmp_path / "fram"
    proc, ports, said = start_devices(3, memory)
    assert "3 devices, macro memory in" in said
    try:
        assert ports == [ports[0], ports[0] + 1, ports[0] + 2]
        assert asyncio.run(word_orders(ports)) == [0, 0, 0]
        (tmp_path / "fleet.toml").write_text(
            "".join(
                f'[targets.cell{k}]\ntcp = "127.0.0.1:{port}"\n'
                for k, port in enumerate(ports, start=1)))
        fleet = mpc("flash", "job.mp", "--fleet", "fleet.toml", "--json", cwd=tmp_path)
        assert fleet.returncode == EXIT_OK, fleet.stderr
        summary = json.loads(fleet.stdout)
        assert summary["ok"] and [d["name"] for d in summary["devices"]] == [
            "cell1", "cell2", "cell3"]
        one = mpc("flash", "other.mp", "--tcp", f"127.0.0.1:{ports[1]}", "--no-identity",
                  cwd=tmp_path)
        assert one.returncode == EXIT_OK, one.stderr
    finally:
        out = stop_devices(proc)
    assert "stopped" in out
    programs = [set(json.loads((memory / f"device-{k}.json").read_text())["programs"])
                for k in (1, 2, 3)]
    assert programs[0] == programs[2] == {"mp3", "mp4"}
    assert programs[1] == {"mp3", "mp4", "mp7"}
    again, ports, said = start_devices(3, memory, "--duration", "0.5")
    again.communicate(timeout=30)
    assert again.returncode == 0 and "3 devices, macro memory in" in said
    assert "(3 with programs)" in said


def test_devices_take_tcp_only_and_a_directory_for_their_memory(tmp_path: Path) -> None:
    serial = mpc("sim", "--devices", "2", "--serial", "pty", "--duration", "0",
                 cwd=tmp_path)
    assert serial.returncode == EXIT_USAGE and "Modbus TCP only" in serial.stderr
    (tmp_path / "memory.json").write_text("{}")
    file = mpc("sim", "--devices", "2", "--tcp", "0", "--memory", "memory.json",
               "--duration", "0", cwd=tmp_path)
    assert file.returncode == EXIT_USAGE and "names a directory" in file.stderr
    single = mpc("sim", "--tcp", "0", "--memory", str(tmp_path), "--duration", "0",
                 cwd=tmp_path)
    assert single.returncode == EXIT_USAGE and "is a directory" in single.stderr
    past = mpc("sim", "--devices", "3", "--tcp", "127.0.0.1:65534", "--duration", "0",
               cwd=tmp_path)
    assert past.returncode == EXIT_USAGE and "past 65535" in past.stderr
    watched = mpc("sim", "--devices", "2", "--tcp", "0", "--monitor", "0", "--duration", "0",
                  cwd=tmp_path)
    assert watched.returncode == EXIT_USAGE and "watches one device" in watched.stderr
