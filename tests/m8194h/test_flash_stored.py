"""Stored means stored: a real `mpc sim --memory F` killed with SIGKILL right after its
download status reads verified (or right after `mpc flash` exits 0) holds every program and
the build manifest in F when it starts again, as the device's FRAM does."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from simproc import start_sim

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.flash import image_from_build
from mplang.m8194h.flash.manifest import Manifest, MdRange, read_manifest
from mplang.m8194h.flash.registers import STATE_REGISTER, STATUS_FIRST
from mplang.m8194h.modbus import DeviceLink, Endpoint

pytestmark = pytest.mark.skipif(os.name != "posix", reason="SIGKILL is POSIX")

SOURCE = """MP {slot} job{slot}
    VAR1 = VAR1 + {slot}
    VAR2 = VAR1 * 2
END MP
"""


def kill(proc: subprocess.Popen[str]) -> None:
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    assert proc.stdout is not None
    proc.stdout.close()


async def download_until_verified(port: int, slot: int) -> list[list[int]]:
    """Create, lines and close over raw Modbus, then poll 100-114 until the status names
    the slot with no error. Returns the program's lines (as they must be stored)."""
    build = compile_source(SOURCE.format(slot=slot), f"job{slot}.mp")
    assert build.ok
    program = image_from_build(build).programs[0]
    link = DeviceLink(Endpoint(host="127.0.0.1", port=port, timeout=1.0))
    await link.open()
    try:
        for frame in program.frames:
            await link.write_frame(frame)
        while True:
            registers = await link.read_input(STATE_REGISTER, STATUS_FIRST + 5 - STATE_REGISTER)
            if registers[0] == 0 and registers[STATUS_FIRST - STATE_REGISTER:] == \
                    [slot, 0, 0, 0, 0]:
                return program.frames[1:-1]
    finally:
        link.close()


def test_a_verified_download_survives_a_kill_right_after_it(tmp_path: Path) -> None:
    """Several rounds, each on the memory the last kill left: every program downloaded
    before a kill is in the file, frame for frame, and the simulator starts from it."""
    memory = tmp_path / "fram.json"
    expected: dict[str, list[list[int]]] = {}
    for slot in (3, 17, 42, 101, 7):
        proc, port = start_sim("--memory", str(memory))
        try:
            lines = asyncio.run(download_until_verified(port, slot))
        finally:
            kill(proc)  # the moment the status read verified: no chance for a timer
        expected[f"mp{slot}"] = lines
        stored = json.loads(memory.read_text(encoding="utf-8"))["programs"]
        assert stored == expected
        assert not memory.with_name(memory.name + ".tmp").exists()
    proc, _port = start_sim("--memory", str(memory))  # the file loads (validated as a download)
    kill(proc)


def test_mpc_flash_then_kill_keeps_the_programs_and_the_manifest(tmp_path: Path) -> None:
    """`mpc flash` exits 0, the simulator is killed at once: restarted from its file it
    holds the programs and a build manifest that names them."""
    memory = tmp_path / "fram.json"
    source = tmp_path / "job.mp"
    for round_no in range(2):
        source.write_text(SOURCE.format(slot=10 + round_no) + SOURCE.format(slot=60),
                          encoding="utf-8")
        proc, port = start_sim("--memory", str(memory))
        try:
            done = subprocess.run(
                [sys.executable, "-m", "mplang", "flash", str(source), "--tcp",
                 f"127.0.0.1:{port}", "--record", str(tmp_path / "record.json"), "--force"],
                capture_output=True, text=True, timeout=120, cwd=tmp_path)
        finally:
            kill(proc)
        assert done.returncode == 0, done.stdout + done.stderr
        programs = json.loads(memory.read_text(encoding="utf-8"))["programs"]
        assert {f"mp{10 + round_no}", "mp60"} <= set(programs)
        proc, port = start_sim("--memory", str(memory))
        try:
            manifest = asyncio.run(_manifest(port))
        finally:
            kill(proc)
        assert {p.slot_label for p in manifest.programs} == {f"MP{10 + round_no}", "MP60"}


async def _manifest(port: int) -> Manifest:
    link = DeviceLink(Endpoint(host="127.0.0.1", port=port, timeout=1.0))
    await link.open()
    try:
        return await read_manifest(link, MdRange(768, 1023), 0)
    finally:
        link.close()


def test_a_memory_file_that_cannot_be_written_fails_the_close_and_stops_the_simulator(
        tmp_path: Path) -> None:
    """The close whose memory cannot be stored is answered SLAVE DEVICE FAILURE (never
    acknowledged as stored), and the simulator stops with its "cannot write" error."""
    from mplang.m8194h.modbus import DeviceException
    from mplang.m8194h.sim.controller import VirtualController
    from mplang.m8194h.sim.service import Endpoints, ServiceError, SimOptions, serve

    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the memory's folder should be\n", encoding="utf-8")
    options = SimOptions(tcp=("127.0.0.1", 0), memory=blocker / "fram.json")
    build = compile_source(SOURCE.format(slot=3), "job3.mp")
    assert build.ok
    frames = image_from_build(build).programs[0].frames

    async def scenario() -> tuple[int, str]:
        endpoints = Endpoints()
        stop_event = asyncio.Event()
        served = asyncio.ensure_future(serve(options, VirtualController(), lambda _t: None,
                                             stop_event, endpoints))
        while endpoints.tcp is None:
            await asyncio.sleep(0.01)
        link = DeviceLink(Endpoint(host="127.0.0.1", port=endpoints.tcp[1], timeout=1.0))
        await link.open()
        code = 0
        try:
            for frame in frames[:-1]:
                await link.write_frame(frame)
            try:
                await link.write_frame(frames[-1])
            except DeviceException as exc:
                code = exc.code
        finally:
            link.close()
        with pytest.raises(ServiceError) as stopped:
            await asyncio.wait_for(served, 5)
        return code, str(stopped.value)

    code, message = asyncio.run(scenario())
    assert code == 0x04
    assert "cannot write macro memory" in message and "fram.json" in message
