"""`mpc status --fleet FILE` (issue 17 item 3): every `[targets.NAME]` device of a fleet file
read concurrently, one row each (reachable, firmware, the manifest's build id and flash
time, the running program, the verdict against the build), against three `mpc sim`
processes over real loopback Modbus TCP and a fourth address where nothing listens."""

from __future__ import annotations

import asyncio
import itertools
import json
import socket
import subprocess
import sys
from pathlib import Path

from pymodbus.client import AsyncModbusTcpClient
from simproc import start_sim

from mplang.cli.common import EXIT_NO_DEVICE, EXIT_OK, EXIT_OUT_OF_SYNC
from mplang.family.face import FamilyBuild, StatusJob
from mplang.ir.unit import Options
from mplang.m8194h.modbus_server import DeviceFace, Interpose, SimClock, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.status import Builds
from mplang.m8194h.status_fleet import read_all, verdict
from mplang.tools.project import Target

JOB = "MP 3 first\n    SET_V X, 1000\n    FIXED_MOVE X, 100\nEND MP\n" \
      "MP 4 second\n    VAR1 = 7\nEND MP\n" \
      "MP 5 spin\nLABEL top\n    VAR2 = 1\n    GOTO top\nEND MP\n"
OTHER = JOB.replace("VAR1 = 7", "VAR1 = 8")


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=120, cwd=cwd)


async def call(port: int, mp: int) -> None:
    """Call MPn as a host does: holding register 8 (RS 11439-11446)."""
    client = AsyncModbusTcpClient("127.0.0.1", port=port)
    try:
        assert await client.connect()
        assert not (await client.write_register(8, mp, device_id=1)).isError()
    finally:
        client.close()


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def fleet_file(path: Path, ports: dict[str, int]) -> Path:
    text = ""
    for name, port in ports.items():
        text += f'\n[targets.{name}]\ntcp = "127.0.0.1:{port}"\n'
    path.write_text(text)
    return path


def test_manual_3_19_fleet_status_table_json_and_exit_codes(tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text(JOB)
    (tmp_path / "other.mp").write_text(OTHER)
    sims = [start_sim("--duration", "900") for _ in range(3)]  # a safety net: ended below
    try:
        ports = {"cell1": sims[0][1], "cell2": sims[1][1], "cell3": sims[2][1],
                 "cell4": closed_port()}
        for name, source in (("cell1", "job.mp"), ("cell2", "other.mp")):
            flashed = mpc(tmp_path, "flash", source, "--tcp", f"127.0.0.1:{ports[name]}",
                          "--record", "r.json")
            assert flashed.returncode == EXIT_OK, flashed.stderr
        asyncio.run(call(ports["cell1"], 5))  # MP5 runs for ever: the RUNNING column
        everything = fleet_file(tmp_path / "fleet.toml", ports)
        table = mpc(tmp_path, "status", "job.mp", "--fleet", str(everything), "--jobs",
                    "2")
        assert table.returncode == EXIT_NO_DEVICE, table.stdout + table.stderr
        lines = table.stdout.splitlines()
        assert lines[0].split() == ["DEVICE", "ADDRESS", "REACHABLE", "FIRMWARE", "BUILD",
                                    "FLASHED", "RUNNING", "SYNC"]
        rows = {line.split()[0]: line for line in lines[1:5]}
        assert rows["cell1"].endswith("MP5      in sync") and " yes " in rows["cell1"]
        assert "0x01000000" in rows["cell1"]
        assert rows["cell2"].endswith("differs (1 slot)")
        assert rows["cell3"].endswith("unknown (no manifest)")
        assert rows["cell4"].split()[2:] == ["no", "-", "-", "-", "-", "unreachable"]
        assert lines[5] == (f"cell4: cannot connect to 127.0.0.1:{ports['cell4']} (Modbus "
                            "TCP): connection refused (nothing listens on that port)")

        listed = mpc(tmp_path, "status", "job.mp", "--fleet", str(everything), "--json")
        assert listed.returncode == EXIT_NO_DEVICE
        data = {row["device"]: row for row in json.loads(listed.stdout)}
        assert list(data) == ["cell1", "cell2", "cell3", "cell4"]
        assert data["cell1"]["sync"] == "in sync" and data["cell1"]["reachable"]
        assert data["cell1"]["running"] == "MP5" and data["cell2"]["running"] is None
        assert data["cell1"]["build_id"] and data["cell1"]["flashed"]
        assert data["cell1"]["address"] == f"tcp://127.0.0.1:{ports['cell1']}/1"
        assert data["cell2"]["build_id"] != data["cell1"]["build_id"]
        assert {s["slot"]: s["status"] for s in data["cell2"]["slots"]} == {
            "MP3": "in sync", "MP4": "differs", "MP5": "in sync"}
        assert data["cell3"]["build_id"] is None and "no manifest" in \
            data["cell3"]["manifest_error"]
        assert not data["cell4"]["reachable"] and "connection refused" in data["cell4"]["error"]

        reachable = fleet_file(tmp_path / "up.toml", {k: v for k, v in ports.items()
                                                      if k != "cell4"})
        assert mpc(tmp_path, "status", "job.mp", "--fleet", str(reachable)).returncode \
            == EXIT_OUT_OF_SYNC
        synced = fleet_file(tmp_path / "one.toml", {"cell1": ports["cell1"]})
        assert mpc(tmp_path, "status", "job.mp", "--fleet", str(synced), "--jobs",
                   "1").returncode \
            == EXIT_OK
        project = tmp_path / "project"  # the project's own mpc.toml: its sources, its targets
        project.mkdir()
        (project / "job.mp").write_text(JOB)
        (project / "mpc.toml").write_text('[project]\nsources = ["job.mp"]\n\n[targets.cell1]\n'
                                          f'tcp = "127.0.0.1:{ports["cell1"]}"\n')
        own = mpc(project, "status", "--fleet", "mpc.toml")
        assert own.returncode == EXIT_OK and own.stdout.splitlines()[1].endswith("in sync")
    finally:
        for proc, _port in sims:
            proc.terminate()
            proc.wait(10)


def test_fleet_verdicts_by_slot() -> None:
    """A device's verdict follows its slot rows and its manifest."""
    def data(*statuses: str, manifest: dict[str, object] | None = None,
             in_sync: bool = False) -> dict[str, object]:
        return {"slots": [{"status": s} for s in statuses], "in_sync": in_sync,
                "manifest": manifest if manifest is not None else {"build_id": "x"}}

    assert verdict({"manifest": None}) is None  # nothing to compare with
    assert verdict(data("in sync", in_sync=True)) == "in sync"
    assert verdict(data("unknown", manifest={"error": "no manifest"})) == \
        "unknown (no manifest)"
    assert verdict(data("in sync", "differs", "missing")) == "differs (2 slots)"
    assert verdict(data("in sync", "extra")) == "extra (1 slot)"
    assert verdict(data("in sync")) == "differs (downloaded since the manifest)"


class Collected:
    """Where the fleet status prints, kept (a StatusUI)."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def say(self, text: str) -> None:
        self.lines.append(text)

    def out(self, text: str) -> None:
        self.lines.append(text)

    def checked(self, build: FamilyBuild) -> None:
        assert build.ok


def test_fleet_reads_at_most_jobs_devices_at_once() -> None:
    """Five virtual controllers in this process, over real loopback Modbus TCP, read with
    --jobs 2: every request a device serves is numbered in one sequence (one event loop
    orders them, no clock involved), and no more than two devices are ever between their
    first and last request."""
    async def scenario() -> list[tuple[int, int]]:
        order = itertools.count()
        spans: dict[int, list[int]] = {}

        def watcher(n: int) -> Interpose:
            def seen(_fc: int, _address: int, _values: list[int] | None) -> None:
                spans.setdefault(n, []).append(next(order))
            return seen

        servers = []
        for n in range(5):
            face = DeviceFace(VirtualController(), SimClock(1.0), interpose=watcher(n))
            servers.append(await serve_tcp(face, "127.0.0.1", 0))
        try:
            devices = [Target(f"d{n}", host="127.0.0.1", port=port)
                       for n, (_server, port) in enumerate(servers)]
            job = StatusJob(device=devices[0], paths=[], options=Options(),
                            word_order_fixed=False, as_json=True, timeout=1.0, retries=0,
                            fleet=True, devices=devices, jobs=2)
            results = await read_all(job, None, Builds(job, Collected()))
            assert all(isinstance(r, dict) for r in results), results
        finally:
            for server, _port in servers:
                await stop(server)
        return [(min(seen), max(seen)) for seen in spans.values()]

    intervals = asyncio.run(scenario())
    assert len(intervals) == 5
    for _first, last in intervals:  # how many devices are mid-read at each last request
        assert sum(1 for a, b in intervals if a <= last <= b) <= 2
