"""The flash record's journal (issue 28): a fleet's saves append to `RECORD.journal` and the
file is rewritten only when the journal has grown as large as it (and at the end of the
command), so a fleet of N devices costs O(N) writes. Every reader applies the journal, so it
sees the facts it saw when the whole file was rewritten after each device; a `mpc flash
--fleet` killed with SIGKILL mid-way leaves a record that says what is stored where."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from test_flash import build_of
from test_sim_devices import JOB, start_devices, stop_devices

from mplang.m8194h.flash import RECORD_FORMAT, FlashRecord, image_from_build
from mplang.m8194h.flash.record import JOURNAL_FORMAT, journal_path

HEADER = json.dumps({"format": JOURNAL_FORMAT}) + "\n"


def entry(slots: dict[str, str]) -> dict[str, Any]:
    """A device's entry as the flasher writes one, with these slots and hashes."""
    return {"identity": [1, 2, 3, 4, 5], "word_order": 0, "last_status": [3, 0, 0, 0, 0],
            "slots": {label: {"hash": digest, "name": "p", "source": "job.mp",
                              "build_id": "b", "at": None} for label, digest in slots.items()}}


def old_style_record(path: Path, count: int) -> dict[str, dict[str, Any]]:
    """A record of `count` other devices as an older mpc wrote it (indented, keys sorted)."""
    devices = {f"tcp://192.0.2.{k}:502/1": entry({"MP1": f"h{k}"}) for k in range(count)}
    path.write_text(json.dumps({"format": RECORD_FORMAT, "devices": devices}, indent=1,
                               sort_keys=True) + "\n")
    return devices


def run_device(record: FlashRecord, address: str, slots: dict[str, str]) -> None:
    """What a flasher does with the record for one device: start, verify, save at the end."""
    old = record.entry(address)
    fresh = entry({})
    fresh["slots"] = dict(old["slots"]) if old else {}
    record.start_run(address, old, fresh, list(slots))
    fresh["slots"].update(entry(slots)["slots"])
    record.save()


@pytest.mark.skipif(os.name != "posix", reason="SIGKILL is POSIX")
def test_a_fleet_killed_mid_way_leaves_a_record_that_says_what_is_stored_where(
        tmp_path: Path) -> None:
    """Three devices of `mpc sim --devices 3` and a fourth that never answers: once the
    record names the three, `mpc flash --fleet` is killed with SIGKILL (the silent one still
    waits). The record reads; it names exactly the programs each device's memory holds,
    keeps every entry an older mpc wrote, and the next flash trusts it (nothing written)."""
    (tmp_path / "job.mp").write_text(JOB)
    image = image_from_build(build_of(JOB))
    hashes = {p.slot_label: p.content_hash(0) for p in image.programs}
    record_path = tmp_path / "record.json"
    others = old_style_record(record_path, 40)
    memory = tmp_path / "fram"
    proc, ports, _said = start_devices(3, memory)
    silent = socket.socket()  # listens, never accepts: every request waits for its timeout
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)
    addresses = [f"tcp://127.0.0.1:{port}/1" for port in ports]
    fleet = "".join(f'[targets.cell{k}]\ntcp = "127.0.0.1:{port}"\n'
                    for k, port in enumerate(ports, start=1))
    (tmp_path / "fleet.toml").write_text(
        fleet + f'[targets.silent]\ntcp = "127.0.0.1:{silent.getsockname()[1]}"\n'
        "timeout = 60\nretries = 0\n")
    command = [sys.executable, "-m", "mplang", "flash", "job.mp", "--fleet", "fleet.toml",
               "--record", str(record_path)]
    try:
        flashing = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, text=True)
        try:
            give_up = time.monotonic() + 100  # a bound on the wait, not a figure measured
            while any(FlashRecord(record_path).recorded_slots(a) != set(hashes)
                      for a in addresses):
                assert flashing.poll() is None and time.monotonic() < give_up, \
                    flashing.stderr.read() if flashing.stderr else ""
                time.sleep(0.05)
            journal = journal_path(record_path).read_text()
        finally:
            flashing.send_signal(signal.SIGKILL)
            flashing.communicate(timeout=30)
        silent.close()
        assert journal.startswith(HEADER) and len(journal.splitlines()) >= 4  # not folded
        record = FlashRecord(record_path)
        assert record.problem is None
        for k, address in enumerate(addresses, start=1):
            held = record.entry(address)
            assert held is not None
            assert {label: slot["hash"] for label, slot in held["slots"].items()} == hashes
            stored = json.loads((memory / f"device-{k}.json").read_text())["programs"]
            assert stored == {p.slot_label.lower(): p.frames[1:-1] for p in image.programs}
        assert {a: record.entry(a) for a in others} == others
        assert len(record.devices) == 43  # the silent device: nothing recorded
        plan = subprocess.run([*command, "--dry-run", "--json"], cwd=tmp_path,
                              capture_output=True, text=True, timeout=120)
        assert plan.returncode == 0, plan.stderr
        assert [[p["recorded"] for p in device["programs"]]  # what --dry-run reads too
                for device in json.loads(plan.stdout)["devices"]] == [[True, True]] * 3 + [
                    [False, False]]
        assert journal_path(record_path).read_text() == journal  # a reader writes nothing

        (tmp_path / "fleet.toml").write_text(fleet)  # a device the kill left leased waits
        again = subprocess.run([*command, "--json", "--wait-lease", "60"], cwd=tmp_path,
                               capture_output=True, text=True, timeout=120)
    finally:
        silent.close()
        stop_devices(proc)
    assert again.returncode == 0, again.stderr
    assert [d["unchanged"] for d in json.loads(again.stdout)["devices"]] == [2, 2, 2]
    assert not journal_path(record_path).exists()  # folded into the file at the end
    saved = json.loads(record_path.read_text())
    assert saved["format"] == RECORD_FORMAT and len(saved["devices"]) == 43


def test_a_line_cut_short_by_a_kill_is_dropped_and_cut_off_before_the_next_save(
        tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    old_style_record(path, 5)
    record = FlashRecord(path)
    run_device(record, "left", {"MP3": "a"})
    journal = journal_path(path)
    whole = journal.read_text()
    assert whole.startswith(HEADER) and whole.count("\n") == 2
    with journal.open("a") as out:  # a writer killed mid-line
        out.write('{"address": "right", "entry": {"slots": {"MP3"')
    seen = FlashRecord(path)
    assert seen.problem is None and seen.recorded_slots("left") == {"MP3"}
    assert seen.entry("right") is None
    run_device(seen, "right", {"MP4": "b"})
    lines = journal.read_text().splitlines()
    assert [json.loads(line).get("address") for line in lines] == [None, "left", "right"]
    final = FlashRecord(path)
    assert final.recorded_slots("left") == {"MP3"} and final.recorded_slots("right") == {"MP4"}


@pytest.mark.parametrize("content", [HEADER + '{"address": "x", "entry": 5}\n'
                                     '{"address": "y", "entry": null}\n',
                                     HEADER + "not json\n",
                                     "someone's notes\nmore of them\n"])
def test_a_damaged_or_foreign_journal_is_never_trusted_nor_written(
        tmp_path: Path, content: str) -> None:
    """A journal line that is not an entry could hide the removal of a slot that is being
    rewritten: the whole record is untrusted, and neither file is touched."""
    path = tmp_path / "record.json"
    old_style_record(path, 2)
    before = path.read_bytes()
    journal_path(path).write_text(content)
    record = FlashRecord(path)
    assert record.problem is not None and "journal" in record.problem
    assert record.devices == {}
    run_device(record, "left", {"MP3": "a"})
    record.close()
    assert path.read_bytes() == before and journal_path(path).read_text() == content


def test_a_foreign_journal_appearing_after_loading_is_not_appended_to(tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    old_style_record(path, 3)
    record = FlashRecord(path)
    journal_path(path).write_text("someone's notes\n")
    run_device(record, "left", {"MP3": "a"})
    assert record.refused and journal_path(path).read_text() == "someone's notes\n"


def test_a_fleet_of_saves_rewrites_the_file_a_logarithmic_number_of_times(
        tmp_path: Path) -> None:
    """100 devices saved one after another: the file is rewritten when the journal holds as
    many entries as the file (1, 2, 4, ... devices) and once at the end, not 100 times; after
    every save a fresh reader sees every device saved so far, and the end leaves one file."""
    path = tmp_path / "record.json"
    record = FlashRecord(path)
    rewrites = 0
    last = None
    for k in range(100):
        run_device(record, f"cell{k}", {"MP3": f"h{k}"})
        now = os.stat(path).st_ino, os.stat(path).st_mtime_ns
        rewrites += now != last
        last = now
        seen = FlashRecord(path)
        assert seen.problem is None and len(seen.devices) == k + 1
        assert seen.entry(f"cell{k}") == record.entry(f"cell{k}")
    assert rewrites <= 8
    record.close()
    assert not journal_path(path).exists()
    saved = json.loads(path.read_text())
    assert len(saved["devices"]) == 100 and saved["devices"]["cell7"]["slots"]["MP3"][
        "hash"] == "h7"


def test_parallel_processes_keep_each_others_entries_through_the_journal(
        tmp_path: Path) -> None:
    """Two records of one file (two mpc processes): each appends only what it changed, and
    a compaction by one keeps what the other appended."""
    path = tmp_path / "record.json"
    old_style_record(path, 4)
    first, second = FlashRecord(path), FlashRecord(path)
    run_device(first, "left", {"MP3": "a"})
    run_device(second, "right", {"MP4": "b"})
    first.close()
    assert not journal_path(path).exists()
    run_device(second, "right", {"MP5": "c"})
    second.close()
    final = FlashRecord(path)
    assert final.recorded_slots("left") == {"MP3"}
    assert final.recorded_slots("right") == {"MP4", "MP5"}
    assert len(final.devices) == 6
