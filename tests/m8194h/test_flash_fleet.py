"""`mpc flash --fleet`: many devices at once, one failing device never stops the others, devices
on one serial bus take turns; the CLI's table, JSON and exit codes."""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
from pathlib import Path

from simproc import start_sim
from test_flash import ARCS, ISR_JOB, assert_all_stored, build_of, device, endpoint

from mplang.cli import EXIT_FLEET_MIXED, EXIT_NO_DEVICE, EXIT_OK
from mplang.family.ptylink import PtyLink
from mplang.m8194h.flash import FlashReport, FleetDevice, flash_fleet, image_from_build
from mplang.m8194h.modbus import Endpoint
from mplang.m8194h.modbus_server import DeviceFace, serve_rtu, serve_tcp, stop


def free_port() -> int:
    """A loopback port nobody listens on (bound, then released)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_a_dead_device_does_not_stop_the_others() -> None:
    image = image_from_build(build_of(ARCS + ISR_JOB))
    faces = [device() for _ in range(4)]

    async def scenario() -> list[FlashReport]:
        served = [await serve_tcp(face, "127.0.0.1", 0) for face in faces]
        try:
            devices = [FleetDevice(f"cell{n}", image, endpoint(port))
                       for n, (_server, port) in enumerate(served)]
            devices.insert(2, FleetDevice("gone", image, endpoint(free_port(), retries=0)))
            return await flash_fleet(devices)
        finally:
            for server, _port in served:
                await stop(server)

    reports = asyncio.run(scenario())
    assert [r.outcome for r in reports] == ["verified", "verified", "no-device", "verified",
                                            "verified"]
    assert all(r.ok for n, r in enumerate(reports) if n != 2)
    for face in faces:
        assert_all_stored(face, image)


def test_devices_on_one_serial_bus_take_turns() -> None:
    """Two RS-M8194H on one RS-485 line: unit 1 answers, unit 2 is absent. Requests to both
    at once would collide on the line; taking turns, unit 1 is flashed and unit 2 reported."""
    image = image_from_build(build_of(ARCS))
    face: DeviceFace = device()

    async def scenario() -> list[FlashReport]:
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=1)
            try:
                bus = link.client_end
                return await flash_fleet([
                    FleetDevice("absent", image, Endpoint(serial=bus, unit=2, timeout=0.2,
                                                          retries=0)),
                    FleetDevice("present", image, Endpoint(serial=bus, unit=1, timeout=0.5))])
            finally:
                await stop(server)

    absent, present = asyncio.run(scenario())
    assert absent.outcome == "no-device" and present.ok, present.error
    assert_all_stored(face, image)


def write_image(tmp_path: Path, image_source: str, name: str = "job.mp") -> Path:
    (tmp_path / name).write_text(image_source)
    return tmp_path / name


def mpc(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=60)


def test_cli_fleet_table_json_and_exit_codes(tmp_path: Path) -> None:
    write_image(tmp_path, ARCS + ISR_JOB)
    sims = [start_sim("--speed", "10"), start_sim("--speed", "10"),
            start_sim("--speed", "10", "--word-order", "1")]
    dead = free_port()
    try:
        (tmp_path / "mpc.toml").write_text(f"""
[project]
sources = ["job.mp"]
word-order = 0

[targets.left]
tcp = "127.0.0.1:{sims[0][1]}"
[targets.right]
tcp = "127.0.0.1:{sims[1][1]}"
timeout = 0.5
[targets.again]
tcp = "127.0.0.1:{sims[0][1]}"

[flash]
record = "state/record.json"
""")
        twice = mpc("flash", "--fleet", "mpc.toml", cwd=tmp_path)
        assert twice.returncode == 2 and "again" in twice.stderr and "left" in twice.stderr
        toml = (tmp_path / "mpc.toml").read_text()
        (tmp_path / "mpc.toml").write_text(toml[:toml.index("[targets.again]")]
                                           + toml[toml.index("[flash]"):])
        both = mpc("flash", "--fleet", "mpc.toml", "--json", cwd=tmp_path)
        assert both.returncode == EXIT_OK, both.stderr
        summary = json.loads(both.stdout)
        assert summary["ok"] and [d["name"] for d in summary["devices"]] == ["left", "right"]
        assert "DEVICE" in both.stderr and "left" in both.stderr
        again = mpc("flash", "--fleet", "mpc.toml", "--json", cwd=tmp_path)
        assert again.returncode == EXIT_OK, again.stderr
        assert [d["unchanged"] for d in json.loads(again.stdout)["devices"]] == [3, 3]

        fleet = tmp_path / "fleet.toml"
        fleet.write_text(f"""
[targets.good]
tcp = "127.0.0.1:{sims[0][1]}"
[targets.gone]
tcp = "127.0.0.1:{dead}"
retries = 0
""")
        one_way = mpc("flash", "--fleet", str(fleet), "--force", cwd=tmp_path)
        assert one_way.returncode == EXIT_NO_DEVICE, one_way.stderr
        table = one_way.stderr
        assert "good" in table and "ok" in table and "gone" in table and "no-device" in table

        fleet.write_text(fleet.read_text() + f"""
[targets.swapped]
tcp = "127.0.0.1:{sims[2][1]}"
""")
        mixed = mpc("flash", "--fleet", str(fleet), "--force", cwd=tmp_path)
        assert mixed.returncode == EXIT_FLEET_MIXED, mixed.stderr
        assert "rejected" in mixed.stderr and "word order" in mixed.stderr
    finally:
        for proc, _port in sims:
            proc.terminate()
            proc.wait(10)


def test_cli_flash_to_a_named_target_and_usage(tmp_path: Path) -> None:
    write_image(tmp_path, ARCS)
    proc, port = start_sim("--speed", "10")
    try:
        (tmp_path / "mpc.toml").write_text(f"""
[project]
sources = "job.mp"
[targets.a]
tcp = "127.0.0.1:{port}"
[targets.b]
tcp = "127.0.0.1:{port}"
""")
        ambiguous = mpc("flash", cwd=tmp_path)
        assert ambiguous.returncode == 2 and "--to NAME" in ambiguous.stderr
        named = mpc("flash", "--to", "b", cwd=tmp_path)
        assert named.returncode == EXIT_OK, named.stderr
        assert "1 program(s) written and verified" in named.stderr
        conflict = mpc("flash", "--fleet", "mpc.toml", "--to", "a", cwd=tmp_path)
        assert conflict.returncode == 2 and "--fleet" in conflict.stderr
    finally:
        proc.terminate()
        proc.wait(10)

