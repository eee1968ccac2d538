"""The build manifest in machine data (RS-M8194H manual 3.19: MD0..MD1023, holding registers
3000 + 2n, non-volatile): its layout (encode/decode, the checksum, a half-written one), and
`flash` writing it into the virtual controller over loopback Modbus TCP only after every
program verified, inside its range and nowhere else.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_flash import assert_all_stored, device, endpoint, tcp_device
from test_flash_incremental import JOB, Counter, image_of

from mplang.m8194h.flash import FlashOptions, FlashRecord, FlashReport, flash
from mplang.m8194h.flash import manifest as mf
from mplang.m8194h.modbus_server import DeviceFace

EXAMPLE = mf.Manifest("0123456789abcdef", "0.1.0", 1_790_000_000, 1, (4, 0, 0x1234, 7, 0),
                      (mf.ManifestProgram("mp", 3, "00112233aabbccdd", "first"),
                       mf.ManifestProgram("isr", 2, "ffeeddccbbaa9988", "edge"),
                       mf.ManifestProgram("mp", 9, "0000000000000001", "")))


def test_manual_3_19_manifest_round_trips() -> None:
    words = mf.encode(EXAMPLE)
    assert words[0] == mf.MAGIC and words[1] >> 16 == mf.VERSION
    assert words[1] & 0xFFFF == len(words)
    assert all(0 <= w <= 0xFFFFFFFF for w in words)
    assert mf.decode(words + [0xDEADBEEF] * 5) == EXAMPLE  # the rest of the range is ignored


def test_manual_3_19_manifest_survives_either_word_order() -> None:
    words = mf.encode(EXAMPLE)
    for order in (0, 1):
        assert mf.from_registers(mf.to_registers(words, order), order) == words


def test_manual_3_19_long_names_are_cut_at_a_character_boundary() -> None:
    long = mf.Manifest("b", "v", 0, 0, (0, 0, 0, 0, 0),
                       (mf.ManifestProgram("mp", 1, "00" * 8, "ääääääää"),))
    decoded = mf.decode(mf.encode(long))
    assert decoded.programs[0].name == "ääääää"  # 12 bytes of UTF-8


@pytest.mark.parametrize("index", range(1, 12))
def test_manual_3_19_checksum_catches_any_changed_word(index: int) -> None:
    words = mf.encode(EXAMPLE)
    if index >= len(words):
        return
    words[index] ^= 0x00010000
    with pytest.raises(mf.ManifestError, match=r"checksum|version|claims"):
        mf.decode(words)


def test_manual_3_19_half_written_manifest_is_recognised() -> None:
    old = mf.encode(EXAMPLE)
    new = mf.encode(mf.Manifest("fedcba9876543210", "0.1.0", 1_790_000_100, 1,
                                (5, 0, 0x1234, 9, 0), EXAMPLE.programs[:2]))
    for cut in range(2, len(new)):  # words 0..cut-1 new (word 0, the magic, is the same)
        torn = new[:cut] + old[cut:]
        with pytest.raises(mf.ManifestError, match=r"checksum|claims|layout"):
            mf.decode(torn)
    with pytest.raises(mf.ManifestError, match="no manifest"):
        mf.decode([0, *new[1:]])  # the writer's own order: magic cleared, then written last


def test_manual_3_19_ranges_are_long_machine_data() -> None:
    assert mf.parse_range("MD960-MD1023") == mf.MdRange(960, 1023)
    assert mf.parse_range(" md0 - md7 ").count == 8
    for text, message in (("960-1023", "not a machine-data range"),
                          ("MD20-MD10", "comes after"), ("MD1000-MD1100", "long machine"),
                          ("MD0-MD3", "at least 8")):
        with pytest.raises(ValueError, match=message):
            mf.parse_range(text)


def test_manual_3_19_too_small_range_says_how_many_md_it_needs() -> None:
    image = image_of(JOB)
    needed = len(mf.encode(mf.manifest_of(image, (0, 0, 0, 0, 0), 0)))
    mf.check_room(image, mf.MdRange(100, 100 + needed - 1))
    with pytest.raises(mf.ManifestError, match=f"needs {needed} MD"):
        mf.check_room(image, mf.MdRange(100, 100 + needed - 2))


def flash_on(face: DeviceFace, counter: Counter, *runs: FlashOptions) -> list[object]:
    image = image_of(JOB)

    async def main() -> list[object]:
        async with tcp_device(face, counter) as (_server, port):
            return [await flash(image, endpoint(port), options) for options in runs]
    return asyncio.run(main())


def test_manual_3_19_flash_writes_the_manifest_inside_its_range_only() -> None:
    face, counter = device(), Counter()
    md = face.controller.md
    for n in range(md.count):  # every MD holds a sentinel before the flash
        md.set_word(n, 0x5A5A0000 + n)
    image = image_of(JOB)
    (report,) = flash_on(face, counter, FlashOptions(identity=mf.MdRange(900, 963)))
    assert report.ok, report.error  # type: ignore[attr-defined]
    manifest = mf.decode([md.word(n) for n in range(900, 964)])
    assert manifest.build_id == image.build_id
    assert [(p.slot_label, p.name) for p in manifest.programs] == [
        ("MP3", "first"), ("MP4", "second"), ("ISR2", "edge")]
    assert mf.matching_slots(manifest, image) == {"MP3", "MP4", "ISR2"}
    last = report.programs[-1].download_status  # type: ignore[attr-defined]
    assert list(manifest.status) == last and last[1] == 2  # ISR2 was downloaded last
    used = len(mf.encode(manifest))
    outside = [n for n in range(md.count) if not 900 <= n < 900 + used]
    assert all(md.word(n) == 0x5A5A0000 + n for n in outside)


def test_manual_3_19_no_identity_never_touches_machine_data() -> None:
    face, counter = device(), Counter()
    (report,) = flash_on(face, counter, FlashOptions())
    assert report.ok  # type: ignore[attr-defined]
    assert all(face.controller.md.word(n) == 0 for n in range(face.controller.md.count))


def test_manual_3_19_range_too_small_is_refused_before_anything_is_written() -> None:
    face, counter = device(), Counter()
    (report,) = flash_on(face, counter, FlashOptions(identity=mf.MdRange(0, 7)))
    assert report.outcome == "rejected"  # type: ignore[attr-defined]
    assert "needs" in report.error and "MD0-MD7 holds 8" in report.error  # type: ignore
    assert counter.frames == 0
    assert all(face.controller.md.word(n) == 0 for n in range(face.controller.md.count))


def test_manual_3_19_unchanged_manifest_is_not_rewritten(tmp_path: Path) -> None:
    """A flash that finds every program already on the device (the manifest vouches for
    them) leaves the manifest as it is, flash time included: MD are non-volatile memory.
    A forced flash writes programs, so it clears the manifest first and writes it anew.
    (The stored time is set back first, so a rewrite shows whatever the clock does.)"""
    face, counter = device(), Counter()
    identity = mf.MdRange(960, 1023)
    (first,) = flash_on(face, counter, FlashOptions(identity=identity))
    assert first.ok  # type: ignore[attr-defined]
    md = face.controller.md
    earlier = dataclasses.replace(mf.decode([md.word(n) for n in range(960, 1024)]),
                                  flashed_at=1_000_000_000)
    for n, word in enumerate(mf.encode(earlier)):
        md.set_word(960 + n, word)
    second, forced = flash_on(face, counter, FlashOptions(
        identity=identity, record=FlashRecord(tmp_path / "record.json")),
        FlashOptions(identity=identity, force=True))
    assert second.ok and second.count("unchanged") == 3  # type: ignore[attr-defined]
    assert second.manifest == mf.to_json(earlier)  # type: ignore[attr-defined]
    assert forced.ok and forced.count("verified") == 3  # type: ignore[attr-defined]
    assert forced.manifest["flashed_at"] >= first.manifest["flashed_at"]  # type: ignore
    assert {**forced.manifest, "flashed_at": 0} == {  # type: ignore
        **first.manifest, "flashed_at": 0}  # type: ignore[attr-defined]


def test_manual_3_19_a_failed_flash_leaves_no_manifest_to_trust() -> None:
    face, counter = device(), Counter()
    identity = mf.MdRange(960, 1023)
    flash_on(face, counter, FlashOptions(identity=identity))
    assert mf.decode([face.controller.md.word(n) for n in range(960, 1024)])
    image = image_of(JOB.replace("SET_V X, 1000", "SET_V X, 2000"))
    del image.programs[0].frames[-1]  # no close frame: the device stays in download state
    del image.programs[0].lines[-1]

    async def main() -> object:
        async with tcp_device(face, counter) as (_server, port):
            return await flash(image, endpoint(port, retries=0), FlashOptions(
                identity=identity))
    report = asyncio.run(main())
    assert not report.ok  # type: ignore[attr-defined]
    with pytest.raises(mf.ManifestError, match="no manifest"):
        mf.decode([face.controller.md.word(n) for n in range(960, 1024)])


def test_manual_3_19_second_computer_trusts_the_manifest_and_writes_only_what_differs(
        tmp_path: Path) -> None:
    """Flash with one record; then from another 'computer' (an empty record elsewhere): the
    manifest and the unchanged download status vouch for every program, nothing is written;
    one program changed: only it is written."""
    identity = mf.MdRange(960, 1023)
    face, counter = device(), Counter()
    changed = JOB.replace("VAR1 = VAR1 + 1", "VAR1 = VAR1 + 2")

    async def main() -> list[FlashReport]:
        async with tcp_device(face, counter) as (_server, port):
            reports = []
            for source, record in ((JOB, tmp_path / "a" / "record.json"),
                                   (JOB, tmp_path / "b" / "record.json"),
                                   (changed, tmp_path / "c" / "record.json")):
                before = counter.frames
                reports.append(await flash(image_of(source), endpoint(port), FlashOptions(
                    identity=identity, record=FlashRecord(record))))
                reports[-1].frames_written = counter.frames - before
            return reports
    first, second, third = asyncio.run(main())
    assert first.ok and first.count("verified") == 3
    assert second.ok and second.count("unchanged") == 3 and second.frames_written == 0
    assert any("trusting the device's build manifest" in n for n in second.notes)
    assert third.ok and [p.status for p in third.programs] == [
        "unchanged", "verified", "unchanged"]
    assert third.frames_written == len(image_of(changed).programs[1].frames)
    assert_all_stored(face, image_of(changed))


def test_manual_3_19_manifest_is_not_trusted_after_another_download(tmp_path: Path) -> None:
    """Another tool downloads a program after the flash: 110-114 change, so the manifest
    no longer vouches, and every program is written again."""
    identity = mf.MdRange(960, 1023)
    face, counter = device(), Counter()
    image = image_of(JOB)
    other = image_of("MP 7 other\n    VAR2 = 1\nEND MP\n")

    async def main() -> FlashReport:
        async with tcp_device(face, counter) as (_server, port):
            await flash(image, endpoint(port), FlashOptions(identity=identity))
            await flash(other, endpoint(port))  # no manifest, no record: the other tool
            return await flash(image, endpoint(port), FlashOptions(
                identity=identity, record=FlashRecord(tmp_path / "record.json")))
    report = asyncio.run(main())
    assert report.ok and report.count("verified") == 3, report.notes
    assert any("changed since its build manifest" in n for n in report.notes)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(0, 0xFFFFFFFF), max_size=40), st.integers(0, 0xFFFF))
def test_manual_3_19_any_md_contents_decode_or_are_refused(body: list[int], low: int) -> None:
    """Whatever another tool left in the range, with a valid-looking header and checksum
    or not: a manifest or ManifestError, nothing else."""
    words = [mf.MAGIC, (mf.VERSION << 16) | (mf.HEADER_WORDS + len(body)), 0, 0, 0, 0, low,
             *body]
    words[2] = mf._crc(words)
    for candidate in (words, words[:len(words) // 2], [mf.MAGIC, *body]):
        with contextlib.suppress(mf.ManifestError):
            mf.decode(candidate)
