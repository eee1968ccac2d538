"""Incremental flashing: the record per device, what it trusts, and `--force`.

Every case runs against the virtual controller over loopback Modbus TCP and counts the frames
the device really received (the server's packet hook), not what the flasher says it sent.
"""

from __future__ import annotations

import asyncio
import json
import os
import stat
import threading
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from test_flash import assert_all_stored, build_of, device, endpoint, tcp_device

from mplang.m8194h.flash import (
    FlashImage,
    FlashOptions,
    FlashRecord,
    FlashReport,
    flash,
    image_from_build,
    render_plan,
)
from mplang.m8194h.modbus_server import DeviceFace

JOB = """MP 3 first
    SET_V X, 1000
    FIXED_MOVE X, 100
END MP
MP 4 second
    VAR1 = VAR1 + 1
END MP
ISR 2 edge
    VAR5 = 1
END ISR
"""


def image_of(source: str) -> FlashImage:
    return image_from_build(build_of(source))


class Counter:
    """Counts FC16 writes at holding register 8000 (frames) arriving at the device, and
    calls `on_frame` (if set) when one arrives."""

    def __init__(self) -> None:
        self.frames = 0
        self.on_frame: Callable[[], None] | None = None

    def __call__(self, sending: bool, data: bytes) -> bytes:
        # a Modbus TCP request: MBAP (7 bytes), function code, address (2 bytes)
        if not sending and len(data) > 9 and data[7] == 16 and data[8:10] == b"\x1f\x40":
            self.frames += 1
            if self.on_frame is not None:
                self.on_frame()
        return data


Flash = Callable[[FlashImage, FlashOptions], Awaitable[FlashReport]]


def run_on_one_device(steps: Callable[[Flash, DeviceFace, Counter], Awaitable[None]]) -> None:
    async def main() -> None:
        face, counter = device(), Counter()
        async with tcp_device(face, counter) as (_server, port):
            async def do(image: FlashImage, options: FlashOptions) -> FlashReport:
                return await flash(image, endpoint(port), options)
            await steps(do, face, counter)
    asyncio.run(main())


def test_unchanged_image_writes_nothing_and_one_change_writes_one_program(
        tmp_path: Path) -> None:
    record = FlashRecord(tmp_path / "record.json")
    options = FlashOptions(record=record, address="bench")

    async def steps(do: Flash, face: DeviceFace, counter: Counter) -> None:
        image = image_of(JOB)
        first = await do(image, options)
        assert first.ok and first.count("verified") == 3
        assert counter.frames == sum(len(p.frames) for p in image.programs)
        assert_all_stored(face, image)

        counter.frames = 0
        again = await do(image, options)
        assert again.ok and again.count("unchanged") == 3 and again.count("verified") == 0
        assert counter.frames == 0 and again.frames_written == 0

        changed = image_of(JOB.replace("VAR1 + 1", "VAR1 + 2"))
        third = await do(changed, options)
        assert third.ok
        assert [p.status for p in third.programs] == ["unchanged", "verified", "unchanged"]
        assert counter.frames == len(changed.programs[1].frames)
        assert_all_stored(face, changed)

        counter.frames = 0
        forced = await do(changed, FlashOptions(record=record, address="bench", force=True))
        assert forced.ok and forced.count("verified") == 3
        assert counter.frames == sum(len(p.frames) for p in changed.programs)

    run_on_one_device(steps)
    saved = json.loads((tmp_path / "record.json").read_text())
    assert saved["format"] == "mpc-flash-record/1"
    assert set(saved["devices"]["bench"]["slots"]) == {"MP3", "MP4", "ISR2"}


def test_a_download_by_someone_else_makes_the_record_untrusted(tmp_path: Path) -> None:
    record = FlashRecord(tmp_path / "record.json")
    options = FlashOptions(record=record, address="bench")

    async def steps(do: Flash, face: DeviceFace, counter: Counter) -> None:
        image = image_of(JOB)
        assert (await do(image, options)).ok
        # another tool downloads MP4 (without mpc): the download status registers change
        other = image_of("MP 4 second\n    VAR1 = 7\nEND MP\n")
        assert (await do(other, FlashOptions())).ok
        counter.frames = 0
        again = await do(image, options)
        assert again.ok and again.count("verified") == 3
        assert any("download status" in note for note in again.notes)
        assert counter.frames == sum(len(p.frames) for p in image.programs)
        assert_all_stored(face, image)

    run_on_one_device(steps)


def test_another_device_at_the_same_address_is_not_trusted(tmp_path: Path) -> None:
    record = FlashRecord(tmp_path / "record.json")
    options = FlashOptions(record=record, address="bench")

    async def steps(do: Flash, face: DeviceFace, _counter: Counter) -> None:
        image = image_of(JOB)
        assert (await do(image, options)).ok
        # a different unit answers at the same address: another firmware version
        face.registers.identity = {**face.registers.identity, "rsm_firmware": 0x01010000}
        again = await do(image, options)
        assert again.ok and again.count("verified") == 3
        assert any("not the one recorded" in note for note in again.notes)

    run_on_one_device(steps)


def test_a_cut_short_download_is_never_recorded_as_done(tmp_path: Path) -> None:
    """The entry of a program is dropped before its download starts: if the run dies in the
    middle, the next run writes that program again."""
    record = FlashRecord(tmp_path / "record.json")
    options = FlashOptions(record=record, address="bench")

    async def steps(do: Flash, face: DeviceFace, counter: Counter) -> None:
        image = image_of(JOB)
        assert (await do(image, options)).ok
        changed = image_of(JOB.replace("VAR1 + 1", "VAR1 + 3"))
        task = asyncio.ensure_future(do(changed, options))
        counter.on_frame = task.cancel  # Ctrl-C as the changed program's create arrives
        with pytest.raises(asyncio.CancelledError):
            await task
        counter.on_frame = None
        saved = json.loads((tmp_path / "record.json").read_text())
        assert "MP4" not in saved["devices"]["bench"]["slots"]
        final = await do(changed, FlashOptions(record=FlashRecord(tmp_path / "record.json"),
                                               address="bench"))
        assert final.ok and final.programs[1].status == "verified"
        assert_all_stored(face, changed)

    run_on_one_device(steps)


@pytest.mark.parametrize("content", ["{ not json", "victim's notes\n",
                                     '{"format": "something else", "devices": {}}'])
def test_a_file_that_is_not_a_record_is_never_replaced(tmp_path: Path, content: str) -> None:
    """Issue 19 item 6: the record path may name someone else's file (before, a damaged or
    foreign file was replaced by the record). The format tag is checked before replacing:
    the flash still verifies every program, says why nothing is recorded, and leaves the file
    byte for byte."""
    path = tmp_path / "record.json"
    path.write_text(content)
    record = FlashRecord(path)
    assert record.problem and "left as it is" in record.problem

    async def steps(do: Flash, _face: DeviceFace, _counter: Counter) -> None:
        result = await do(image_of(JOB), FlashOptions(record=record, address="bench"))
        assert result.ok and result.count("verified") == 3
        assert any("is not an mpc flash record" in note and "records nothing" in note
                   for note in result.notes)

    run_on_one_device(steps)
    assert path.read_text() == content
    assert [p.name for p in tmp_path.iterdir()] == ["record.json"]  # no temporary left


def test_a_record_path_that_is_a_fifo_or_directory_is_neither_opened_nor_replaced(
        tmp_path: Path) -> None:
    fifo, folder = tmp_path / "fifo.json", tmp_path / "folder.json"
    os.mkfifo(fifo)
    folder.mkdir()
    for path in (fifo, folder):
        records: list[FlashRecord] = []
        worker = threading.Thread(target=lambda at=path, into=records: into.append(
            FlashRecord(at)), daemon=True)
        worker.start()
        worker.join(60)
        if worker.is_alive():  # a FIFO opened for reading waits for a writer: release it
            with open(fifo, "w"):
                pass
            pytest.fail("the record's FIFO was opened")
        (record,) = records
        assert record.refused == "is not a regular file"
        record.devices["bench"] = {"slots": {}}
        record.save()
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and folder.is_dir() and not any(folder.iterdir())


def test_a_record_or_an_empty_file_is_replaced_and_a_file_swapped_in_later_is_not(
        tmp_path: Path) -> None:
    path = tmp_path / "record.json"
    path.write_text("")
    record = FlashRecord(path)
    assert record.problem is None
    record.devices["bench"] = {"slots": {"MP3": {"hash": "x"}}}
    record.save()
    again = FlashRecord(path)
    assert again.problem is None and again.recorded_slots("bench") == {"MP3"}
    path.write_text("not a record any more\n")  # replaced by something else since loading
    again.save()
    assert path.read_text() == "not a record any more\n" and again.refused


def test_dry_run_marks_the_programs_the_record_holds() -> None:
    image = image_of(JOB)
    text = render_plan(image, recorded=frozenset({"MP4"}))
    marked = [line for line in text.splitlines() if "recorded on the device" in line]
    assert len(marked) == 1 and marked[0].startswith("MP4 second")


class CountingRecord(FlashRecord):
    """A record that counts its saves and keeps what the file said at each."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.saved: list[dict[str, object]] = []

    def save(self) -> None:
        super().save()
        self.saved.append(json.loads(self.path.read_text()))


def test_the_record_is_saved_once_per_device_run_not_after_every_program(
        tmp_path: Path) -> None:
    """Issue 16: a fleet rewrote the whole record after every program of every device. A
    first flash saves each device's entry once, at its end; a flash that changes a recorded
    program saves first (the file must stop vouching for that slot before it is written)
    and once more at the end."""
    record = CountingRecord(tmp_path / "record.json")
    options = FlashOptions(record=record, address="bench")

    async def steps(do: Flash, face: DeviceFace, _counter: Counter) -> None:
        image = image_of(JOB)
        assert (await do(image, options)).ok
        assert len(record.saved) == 1
        assert set(record.saved[0]["devices"]["bench"]["slots"]) == {  # type: ignore[index]
            "MP3", "MP4", "ISR2"}
        assert (await do(image, options)).ok  # unchanged: nothing to write, nothing to save
        assert len(record.saved) == 1
        changed = image_of(JOB.replace("VAR1 + 1", "VAR1 + 3"))
        assert (await do(changed, options)).ok
        assert len(record.saved) == 3
        first, last = (saved["devices"]["bench"]["slots"]  # type: ignore[index]
                       for saved in record.saved[1:])
        assert set(first) == {"MP3", "ISR2"} and set(last) == {"MP3", "MP4", "ISR2"}
        assert_all_stored(face, changed)

    run_on_one_device(steps)
