"""One downloader at a time: the download lease `mpc flash` keeps in machine data, against
a real `mpc sim` and real `mpc flash` processes (and the library where only the device's
answers matter)."""

from __future__ import annotations

import asyncio
import json
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from simproc import start_sim

from mplang.cli import EXIT_LEASED, EXIT_OK
from mplang.family.face import CommandError
from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.flash import FlashOptions, flash, image_from_build
from mplang.m8194h.flash import lease as leases
from mplang.m8194h.modbus import Endpoint
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

SETTINGS = leases.LeaseSettings.of(catalogue.load().profile)


def long_source(tag: int) -> str:
    """Three programs long enough (400, 400 and 120 lines) that two flashes started
    together overlap; `tag` makes each flash's content its own."""
    return "".join(f"MP {slot} p{slot}\n" + f"    VAR{tag} = VAR{tag} + {slot}\n" * lines
                   + "END MP\n" for slot, lines in ((156, 400), (157, 400), (151, 120)))


def frames_of(source: str) -> dict[str, list[list[int]]]:
    build = compile_source(source, "job.mp")
    assert build.ok
    return {f"mp{p.slot}": p.frames[1:-1] for p in image_from_build(build).programs}


def mpc_flash(source: Path, port: int, record: Path, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "mplang", "flash", str(source), "--tcp", f"127.0.0.1:{port}",
         "--record", str(record), "--force", "--timeout", "0.5", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})  # its progress as it happens


def finish(proc: subprocess.Popen[str]) -> tuple[int, str]:
    output, _ = proc.communicate(timeout=180)
    return proc.returncode, output


def stop_sim(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    proc.communicate(timeout=20)


def test_two_mpc_flash_at_once_never_empty_a_slot_and_the_loser_names_the_winner(
        tmp_path: Path) -> None:
    """Issue 23 finding 5: two `mpc flash` processes started together against one `mpc sim`
    (they race for the lease), two rounds. Every round: one exits 0, the other exits 19
    before touching a slot, naming the winner (host, pid, when it started); every slot
    holds the winner's program whole, never an empty slot, never a source line blamed."""
    memory = tmp_path / "fram.json"
    sources = [tmp_path / "a.mp", tmp_path / "b.mp"]
    expected = []
    for tag, path in enumerate(sources, start=1):
        path.write_text(long_source(tag), encoding="utf-8")
        expected.append(frames_of(long_source(tag)))
    sim, port = start_sim("--memory", str(memory))
    try:
        for round_no in range(2):
            procs = [mpc_flash(path, port, tmp_path / f"r{k}.json")
                     for k, path in enumerate(sources)]
            results = [finish(proc) for proc in procs]
            codes = sorted(code for code, _output in results)
            assert codes == [EXIT_OK, EXIT_LEASED], results
            won = next(k for k, (code, _output) in enumerate(results) if code == EXIT_OK)
            output = results[1 - won][1]
            assert re.search(rf"leased by mpc flash on {re.escape(socket.gethostname())} "
                             rf"\(pid {procs[won].pid}, lease [0-9a-f]{{8}}\) since "
                             r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\dZ", output), output
            assert "nothing was written" in output and "slot line" not in output, output
            programs = json.loads(memory.read_text(encoding="utf-8"))["programs"]
            for slot, frames in expected[won].items():
                assert programs[slot] == frames, f"round {round_no}: {slot}"
    finally:
        stop_sim(sim)


def test_a_flash_that_waits_for_the_lease_flashes_after_the_other(tmp_path: Path) -> None:
    """--wait-lease S: two flashes started together, both willing to wait: the one that
    finds the lease held waits for it to be given back, then writes its own programs;
    both exit 0 and the device holds the waiter's."""
    memory = tmp_path / "fram.json"
    sources = [tmp_path / "a.mp", tmp_path / "b.mp"]
    for tag, path in enumerate(sources, start=1):
        path.write_text(long_source(tag), encoding="utf-8")
    sim, port = start_sim("--memory", str(memory))
    try:
        procs = [mpc_flash(path, port, tmp_path / f"r{k}.json", "--wait-lease", "120")
                 for k, path in enumerate(sources)]
        results = [finish(proc) for proc in procs]
        assert [code for code, _output in results] == [EXIT_OK, EXIT_OK], results
        waited = [k for k, (_code, output) in enumerate(results)
                  if "waiting up to 120 s for the device's lease, held by mpc flash on" in output]
        assert len(waited) == 1, results
        programs = json.loads(memory.read_text(encoding="utf-8"))["programs"]
        assert {k: programs[k] for k in ("mp156", "mp157", "mp151")} == \
            frames_of(long_source(waited[0] + 1))
    finally:
        stop_sim(sim)


def test_parallel_flashes_of_different_devices_keep_both_record_entries(
        tmp_path: Path) -> None:
    """Issue 23 finding 5: two flashes of two devices sharing one flash record; the record
    is locked and merged, so neither entry is lost (each vouches for its three
    programs)."""
    record = tmp_path / "record.json"
    source = tmp_path / "job.mp"
    source.write_text(long_source(3), encoding="utf-8")
    sims = [start_sim(), start_sim()]
    try:
        procs = [subprocess.Popen(
            [sys.executable, "-m", "mplang", "flash", str(source), "--tcp",
             f"127.0.0.1:{port}", "--record", str(record), "--timeout", "0.5"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            for _sim, port in sims]
        for proc in procs:
            code, output = finish(proc)
            assert code == EXIT_OK, output
        devices = json.loads(record.read_text(encoding="utf-8"))["devices"]
        assert {f"tcp://127.0.0.1:{port}/1" for _sim, port in sims} == set(devices)
        for entry in devices.values():  # so the next flash of either writes nothing
            assert set(entry["slots"]) == {"MP151", "MP156", "MP157"}
    finally:
        for sim, _port in sims:
            stop_sim(sim)


# ------------------------------------------------------------- in process, one device
def image(tag: int = 1) -> object:
    build = compile_source(f"MP 5 five\n    VAR{tag} = {tag}\nEND MP\n", "five.mp")
    assert build.ok
    return image_from_build(build)


def put_lease(face: DeviceFace, holder: leases.Holder) -> None:
    """Another client's lease, as its own mpc flash wrote it (MD words are the device's
    32-bit values, whatever the word order)."""
    for k, word in enumerate(leases.encode(holder, SETTINGS.md.count)):
        face.controller.md.set_word(SETTINGS.md.first + k, word)


def other(renewed_ago: float, seconds: int = 30) -> leases.Holder:
    now = int(time.time())
    return leases.Holder("cell-7-pc", 4242, 0x1A2B3C4D, now - 600, int(now - renewed_ago),
                         seconds)


def run_flash(face: DeviceFace, options: FlashOptions) -> object:
    async def scenario() -> object:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            return await flash(image(), Endpoint(host="127.0.0.1", port=port, timeout=0.2),
                               options)
        finally:
            await stop(server)
    return asyncio.run(scenario())


def test_a_held_lease_refuses_before_anything_is_written() -> None:
    face = DeviceFace(VirtualController(), SimClock(1.0))
    put_lease(face, other(renewed_ago=2))
    before = dict(face.controller.tables)
    report = run_flash(face, FlashOptions(lease=SETTINGS))
    assert report.outcome == "leased", report.error  # type: ignore[attr-defined]
    error = str(report.error)  # type: ignore[attr-defined]
    assert "leased by mpc flash on cell-7-pc (pid 4242, lease 1a2b3c4d) since" in error
    assert "expiring in 28 s" in error or "expiring in 27 s" in error, error
    assert face.controller.tables == before and ("mp", 5) not in face.controller.tables
    held = leases.decode([face.controller.md.word(n) for n in range(SETTINGS.md.first,
                                                                     SETTINGS.md.last + 1)])
    assert held is not None and held.token == 0x1A2B3C4D  # the other's lease is untouched


def test_an_expired_lease_is_taken_over_with_a_note_and_given_back() -> None:
    face = DeviceFace(VirtualController(), SimClock(1.0))
    put_lease(face, other(renewed_ago=31))
    report = run_flash(face, FlashOptions(lease=SETTINGS))
    assert report.ok, report.error  # type: ignore[attr-defined]
    assert ("mp", 5) in face.controller.tables
    words = [face.controller.md.word(n) for n in range(SETTINGS.md.first,
                                                        SETTINGS.md.last + 1)]
    assert words == [0] * SETTINGS.md.count  # released


def test_a_lease_taken_by_another_client_mid_flash_stops_before_the_next_program() -> None:
    """Another client overwrites the lease while the first program downloads: the flash
    stops before the second, names that client, exit 19 ("leased"), and leaves its lease
    alone."""
    build = compile_source("MP 5 a\n    VAR1 = 1\nEND MP\nMP 6 b\n    VAR2 = 2\nEND MP\n",
                           "two.mp")
    assert build.ok
    two = image_from_build(build)
    face: DeviceFace
    close = two.programs[0].frames[-1]

    def steal(function_code: int, _address: int, values: list[int] | None) -> int | None:
        if function_code == 16 and values == close:
            put_lease(face, other(renewed_ago=0))
        return None

    face = DeviceFace(VirtualController(), SimClock(1.0), steal)

    async def scenario() -> object:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            return await flash(two, Endpoint(host="127.0.0.1", port=port, timeout=0.2),
                               FlashOptions(lease=SETTINGS))
        finally:
            await stop(server)

    report = asyncio.run(scenario())
    assert report.outcome == "leased"  # type: ignore[attr-defined]
    assert "was taken by mpc flash on cell-7-pc (pid 4242" in str(
        report.error)  # type: ignore[attr-defined]
    assert "stopped before MP6" in str(report.error)  # type: ignore[attr-defined]
    assert ("mp", 6) not in face.controller.tables
    held = leases.decode([face.controller.md.word(n) for n in range(SETTINGS.md.first,
                                                                     SETTINGS.md.last + 1)])
    assert held is not None and held.pid == 4242


def test_a_monitor_write_is_refused_while_a_flash_holds_the_lease() -> None:
    """The dashboard's writes (a call, a variable) check the lease and name its holder;
    stop and emergency stop always go through."""
    from mplang.m8194h.live import Watcher

    face = DeviceFace(VirtualController(), SimClock(1.0))
    put_lease(face, other(renewed_ago=1))

    async def scenario() -> tuple[str, str]:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        watcher = Watcher(Endpoint(host="127.0.0.1", port=port, timeout=0.5))
        try:
            with pytest.raises(CommandError) as caught:
                await watcher.act("set_var", {"name": "VAR3", "value": 7})
            stopped = await watcher.act("emergency_stop", {})
            return str(caught.value) + "|" + caught.value.kind, stopped
        finally:
            watcher.close()
            await stop(server)

    refused, stopped = asyncio.run(scenario())
    assert "refused: the device is leased by mpc flash on cell-7-pc (pid 4242" in refused
    assert refused.endswith("|leased") and face.controller.vars[3] == 0
    assert "emergency stop" in stopped


pytestmark = pytest.mark.skipif(os.name != "posix", reason="subprocess timing on POSIX")


def test_a_client_that_ignores_the_lease_is_detected_and_said_to_hold_none() -> None:
    """A client without a lease (an older mpc, another tool) opens a download just before
    this flash's create frame: detected by the device's state as before (exit 10, nothing
    tidied up), and the message adds that it holds no download lease."""
    from test_flash_faults import job_image
    from test_flash_request_faults import flash_relayed

    image_ = job_image()
    face = DeviceFace(VirtualController(), SimClock(1.0))
    vc = face.controller
    first_create = image_.programs[0].frames[0]
    opened: list[bool] = []

    def other_client_closes() -> None:
        vc.write_subfunction(vc.encoder.close_frame("mp"))

    def interpose(_function_code: int, _address: int, values: list[int] | None) -> int | None:
        if values == first_create and not opened:
            opened.append(True)
            assert vc.write_subfunction(vc.encoder.create_frame("mp", 60)) == 0
            asyncio.get_running_loop().call_later(0.2, other_client_closes)
        return None

    face.interpose = interpose
    outcome = flash_relayed("tcp", face, lambda _r: None, image_,
                            FlashOptions(lease=SETTINGS))
    error = str(outcome.report.error)
    assert outcome.report.outcome == "interrupted", error
    assert "another client is downloading MP60" in error
    assert error.endswith("(it holds no download lease: an older mpc, or another tool)"), error
    words = [vc.md.word(n) for n in range(SETTINGS.md.first, SETTINGS.md.last + 1)]
    assert words == [0] * SETTINGS.md.count  # this flash's lease given back
