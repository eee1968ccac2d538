"""The device manifest (mplang.m8194h.flash.manifest): checks that mutation testing
(`make mutate`, docs/testing.md) found unheld: range boundaries and their messages, and the
JSON form's field names."""

from __future__ import annotations

import asyncio
import dataclasses
import zlib
from collections.abc import Awaitable, Callable
from typing import TypeVar

import pytest
from test_flash import device, endpoint, tcp_device
from test_flash_incremental import JOB, image_of

from mplang.m8194h.flash import manifest as mf
from mplang.m8194h.modbus import DeviceLink
from mplang.m8194h.modbus_server import DeviceFace

T = TypeVar("T")


def test_range_boundaries_and_their_messages() -> None:
    """A one-MD range is too small, not backwards; the smallest range and the last long MD
    are accepted, MD1024 is not."""
    with pytest.raises(ValueError, match=r"^MD5-MD5: a manifest needs at least 8 MD$"):
        mf.parse_range("MD5-MD5")
    assert mf.parse_range("MD0-MD7") == mf.MdRange(0, 7)
    assert str(mf.parse_range("MD1016-MD1023")) == "MD1016-MD1023"
    with pytest.raises(ValueError, match=r"^MD1017-MD1024: the manifest goes in the long"):
        mf.parse_range("MD1017-MD1024")


def test_the_json_form_names_every_field() -> None:
    """`mpc status --json` and the flash report: the field names are the interface."""
    manifest = mf.manifest_of(image_of(JOB), (110, 1, 0, 0, 0), 1700000000)
    data = mf.to_json(manifest)
    assert list(data) == ["format_version", "build_id", "tool_version", "flashed_at",
                          "word_order", "download_status", "programs"]
    assert data["format_version"] == 1 and data["flashed_at"] == 1700000000
    assert data["download_status"] == [110, 1, 0, 0, 0]
    assert data["programs"] == [{"slot": p.slot_label, "name": p.name, "hash": p.hash}
                                for p in manifest.programs]
    assert data["programs"] and data["build_id"] == manifest.build_id
    assert mf.decode(mf.encode(manifest)) == manifest


def test_seven_md_are_one_too_few_and_floats_are_named() -> None:
    with pytest.raises(ValueError, match=r"^MD0-MD6: a manifest needs at least 8 MD$"):
        mf.parse_range("MD0-MD6")
    with pytest.raises(ValueError) as caught:
        mf.parse_range("MD1000-MD1100")
    assert str(caught.value).endswith(
        "(MD1024-MD2047 are floats, whose bit patterns a device may change)")


def test_a_long_name_is_cut_at_a_character_boundary() -> None:
    """Program names keep at most 12 bytes of UTF-8, never half a character: six 'ä' (two
    bytes each) fill the 12; after an 'x', the sixth 'ä' would end at byte 13, so five stay;
    '€' takes three bytes, so four fit."""
    for name, kept in (("ääääääää", "ääääää"), ("xääääääää", "xäääää"),
                       ("abcdefghijklmn", "abcdefghijkl"), ("€€€€€", "€€€€")):
        program = mf.ManifestProgram("mp", 1, "0" * 16, name)
        manifest = mf.Manifest("b", "t", 0, 0, (0, 0, 0, 0, 0), (program,))
        assert mf.decode(mf.encode(manifest)).programs[0].name == kept, name


# -------------------------------------------------------------------------- the layout
def program(n: int) -> mf.ManifestProgram:
    return mf.ManifestProgram("mp", n, f"{n:016x}", f"p{n}")


def test_255_programs_fit_the_count_byte_and_256_are_refused() -> None:
    """Word 6 keeps the number of programs in bits 0-7 (docs/flash.md): 255 at most."""
    full = mf.Manifest("b", "t", 0, 0, (0, 0, 0, 0, 0), tuple(program(n) for n in range(255)))
    words = mf.encode(full)
    assert words[6] & 0xFF == 255
    assert mf.decode(words) == full
    with pytest.raises(ValueError, match=r"^a manifest lists at most 255 programs$"):
        mf.encode(mf.Manifest("b", "t", 0, 0, (0, 0, 0, 0, 0),
                              tuple(program(n) for n in range(256))))


def with_checksum(words: list[int]) -> list[int]:
    """`words` with word 2 set to the CRC-32 of words 1 and 3.. (each big-endian), as the
    layout in docs/flash.md gives it."""
    data = b"".join(w.to_bytes(4, "big") for i, w in enumerate(words) if i not in (0, 2))
    return [*words[:2], zlib.crc32(data), *words[3:]]


def test_the_header_alone_with_a_good_checksum_is_no_complete_manifest() -> None:
    """Seven words (the header, total 7, checksum right) hold no build id or tool version:
    their contents do not fit the layout; six words are not even a header."""
    header = with_checksum([mf.MAGIC, (mf.VERSION << 16) | 7, 0, 0, 0, 0, 0])
    with pytest.raises(mf.ManifestError,
                       match=r"^the manifest's contents do not fit its layout$"):
        mf.decode(header)
    with pytest.raises(mf.ManifestError, match=r'^no manifest \(the first MD of the range is '
                                               r'not "MPCM"\)$'):
        mf.decode(header[:6])


@pytest.mark.parametrize(("change", "message"), [
    (lambda w: [0x4D50434E, *w[1:]], r'^no manifest \(the first MD of the range is not '
                                     r'"MPCM"\)$'),
    (lambda w: [w[0], (2 << 16) | (w[1] & 0xFFFF), *w[2:]],
     r"^manifest format version 2, this mpc reads 1$"),
    (lambda w: with_checksum([w[0], (1 << 16) | 6, *w[2:]]),
     r"^the manifest claims 6 MD, the range holds 12$"),
    (lambda w: with_checksum([w[0], (1 << 16) | 13, *w[2:]]),
     r"^the manifest claims 13 MD, the range holds 12$"),
    (lambda w: [*w[:2], w[2] ^ 1, *w[3:]],
     r"^the manifest's checksum fails: it was cut short while being written, or something "
     r"else wrote into its MD range$"),
])
def test_each_refusal_of_decode_says_why_in_its_own_words(
        change: Callable[[list[int]], list[int]], message: str) -> None:
    """The messages `mpc status` and the flash notes show, word for word."""
    words = mf.encode(mf.Manifest("b", "t", 0, 0, (0, 0, 0, 0, 0), (program(1),)))
    # 7 header words, then 5: "b" and "t" (a length byte each), slot 2 + hash 8 + "p1" 3
    # bytes, 17 bytes padded to 20
    assert len(words) == 12
    assert mf.decode(words).programs == (program(1),)
    with pytest.raises(mf.ManifestError, match=message):
        mf.decode(change(words))


# ------------------------------------------------- store and vouched, on a virtual device
MD = mf.MdRange(960, 1023)
STATUS = (2, 0, 0, 0, 0)


def on_device(face: DeviceFace, work: Callable[[DeviceLink], Awaitable[T]]) -> T:
    """Run `work` with a link to `face` over loopback Modbus TCP."""
    async def main() -> T:
        async with tcp_device(face) as (_server, port), DeviceLink(endpoint(port)) as link:
            return await work(link)
    return asyncio.run(main())


def held_words(face: DeviceFace, md: mf.MdRange = MD) -> list[int]:
    return [face.controller.md.word(n) for n in range(md.first, md.last + 1)]


def test_store_writes_a_new_manifest_and_reads_it_back() -> None:
    face, image = device(), image_of(JOB)
    manifest, written = on_device(face, lambda link: mf.store(link, MD, image, STATUS, 100))
    assert written and manifest == mf.manifest_of(image, STATUS, 100)
    assert mf.decode(held_words(face)) == manifest


def test_store_does_not_rewrite_the_same_content_and_keeps_the_first_time() -> None:
    """MD are non-volatile memory: the same manifest but for its time is left alone."""
    face, image = device(), image_of(JOB)
    on_device(face, lambda link: mf.store(link, MD, image, STATUS, 100))
    before = held_words(face)
    face.controller.md.set_word(MD.last, 0x5A5A5A5A)  # past the manifest: must stay
    manifest, written = on_device(face, lambda link: mf.store(link, MD, image, STATUS, 200))
    assert not written and manifest.flashed_at == 100
    assert held_words(face)[:-1] == before[:-1] and face.controller.md.word(MD.last) == \
        0x5A5A5A5A


@pytest.mark.parametrize("spoil", ["status", "checksum"])
def test_store_rewrites_a_manifest_with_other_content_or_a_broken_one(spoil: str) -> None:
    face, image = device(), image_of(JOB)
    on_device(face, lambda link: mf.store(link, MD, image, STATUS, 100))
    status = STATUS
    if spoil == "status":
        status = (4, 0, 0, 0, 0)
    else:
        face.controller.md.set_word(MD.first + 2, face.controller.md.word(MD.first + 2) ^ 1)
    manifest, written = on_device(face, lambda link: mf.store(link, MD, image, status, 200))
    assert written and manifest == mf.manifest_of(image, status, 200)
    assert mf.decode(held_words(face)) == manifest


def test_vouched_says_nothing_without_a_manifest_and_names_every_slot_with_one() -> None:
    face, image = device(), image_of(JOB)
    assert on_device(face, lambda link: mf.vouched(link, MD, image, 0, STATUS)) == ""
    on_device(face, lambda link: mf.store(link, MD, image, STATUS, 100))
    assert on_device(face, lambda link: mf.vouched(link, MD, image, 0, list(STATUS))) == \
        frozenset({"MP3", "MP4", "ISR2"})
    changed = image_of(JOB.replace("VAR1 = VAR1 + 1", "VAR1 = VAR1 + 2"))
    assert on_device(face, lambda link: mf.vouched(link, MD, changed, 0, STATUS)) == \
        frozenset({"MP3", "ISR2"})


@pytest.mark.parametrize(("state", "status"), [(1, STATUS), (2, STATUS), (0, (3, 0, 0, 0, 0)),
                                               (0, (2, 0, 0, 0, 1))])
def test_vouched_refuses_a_device_not_ready_or_with_another_status(
        state: int, status: tuple[int, ...]) -> None:
    face, image = device(), image_of(JOB)
    on_device(face, lambda link: mf.store(link, MD, image, STATUS, 100))
    assert on_device(face, lambda link: mf.vouched(link, MD, image, state, status)) == (
        "the device's download status (input registers 110-114) changed since its build "
        "manifest was written")


def test_vouched_refuses_a_broken_manifest_or_one_of_another_word_order() -> None:
    face, image = device(), image_of(JOB)
    other = dataclasses.replace(mf.manifest_of(image, STATUS, 100),
                                word_order=1 - image.word_order)
    for n, word in enumerate(mf.encode(other)):
        face.controller.md.set_word(MD.first + n, word)
    assert on_device(face, lambda link: mf.vouched(link, MD, image, 0, STATUS)) == \
        "the device's build manifest is for another word order"
    face.controller.md.set_word(MD.first + 2, face.controller.md.word(MD.first + 2) ^ 1)
    assert on_device(face, lambda link: mf.vouched(link, MD, image, 0, STATUS)) == (
        "the manifest's checksum fails: it was cut short while being written, or something "
        "else wrote into its MD range")


def test_write_manifest_refuses_a_range_too_small_and_writes_nothing() -> None:
    face = device()
    words = mf.encode(mf.manifest_of(image_of(JOB), STATUS, 100))
    small = mf.MdRange(960, 960 + len(words) - 2)
    with pytest.raises(mf.ManifestError, match=rf"^the manifest needs {len(words)} MD, "
                                               rf"MD960-MD{small.last} holds {len(words) - 1}$"):
        on_device(face, lambda link: mf.write_manifest(link, small, words, 0))
    assert held_words(face) == [0] * MD.count


@pytest.mark.parametrize(("count", "order"), [(61, 0), (62, 1), (122, 0), (123, 1)])
def test_ranges_around_the_61_md_per_request_are_read_whole(count: int, order: int) -> None:
    """FC3 reads at most 125 registers: the words come in requests of 61 MD (122
    registers); a range of any length reads back exactly what it holds, in either word
    order (holding register 14)."""
    face = device()
    face.controller.word_order = order
    md = mf.MdRange(1024 - count, 1023)
    for n in range(md.first, md.last + 1):
        face.controller.md.set_word(n, 0x10000 * n + 7)
    got = on_device(face, lambda link: mf.read_words(link, md, order))
    assert got == [0x10000 * n + 7 for n in range(md.first, md.last + 1)]


# ---------------------------------------------------------- the second run's survivors
def test_register_114_and_the_padding_follow_the_layout() -> None:
    """Word 6 is register 114 (high 16 bits) | word order (bits 8-15) | count; the body is
    zero-padded to whole words: "b", "t" and one program named "x" make 16 bytes, 4 words
    (a truncated name claiming 12 bytes where 3 and the padding are left does not fit)."""
    status = (41, 0, 0x0CD6, 5, 0x0A)
    manifest = mf.Manifest("b", "t", 0, 1, status, (mf.ManifestProgram("mp", 1, "0" * 16,
                                                                        "x"),))
    words = mf.encode(manifest)
    assert len(words) == 7 + 4
    assert words[6] == (0x0A << 16) | (1 << 8) | 1
    assert words[4:6] == [(41 << 16) | 0, (0x0CD6 << 16) | 5]
    assert mf.decode(words) == manifest  # the name ends exactly where the body ends
    body = b"\x01b\x01t" + b"\x00\x01" + bytes(8) + b"\x0cabc" + bytes(2)  # 20 bytes
    torn = with_checksum([mf.MAGIC, (mf.VERSION << 16) | 12, 0, 0, 0, 0, 1,
                          *(int.from_bytes(body[i:i + 4], "big") for i in range(0, 20, 4))])
    with pytest.raises(mf.ManifestError,
                       match=r"^the manifest's contents do not fit its layout$"):
        mf.decode(torn)


def test_a_build_without_id_and_a_program_without_name_are_empty_texts() -> None:
    image = image_of("MP 5\n    VAR1 = 1\nEND MP\n")
    image.build_id = None
    manifest = mf.manifest_of(image, STATUS, 0)
    assert manifest.build_id == "" and [p.name for p in manifest.programs] == [""]


def test_check_room_suggests_a_range_that_ends_where_the_given_one_ends() -> None:
    image = image_of(JOB)
    needed = len(mf.encode(mf.manifest_of(image, (0, 0, 0, 0, 0), 0)))
    assert needed > 8
    with pytest.raises(mf.ManifestError) as caught:
        mf.check_room(image, mf.MdRange(1016, 1023))
    assert str(caught.value) == (
        f"the build manifest of 3 program(s) needs {needed} MD, and the identity range "
        f"MD1016-MD1023 holds 8: give a larger one (--identity MD{1024 - needed}-MD1023 or "
        "[flash] identity), or --no-identity")
    with pytest.raises(mf.ManifestError, match=r"\(--identity MD0-MD7 or "):
        mf.check_room(image, mf.MdRange(0, 7))  # never below MD0


def test_write_manifest_fills_a_range_exactly_in_few_requests_and_clears_the_magic_first(
        ) -> None:
    """The words go in FC16 requests of at most 61 MD: a manifest of 12 words is the
    cleared magic word, one request for words 1-11, the magic word, one read back."""
    face = device()
    words = mf.encode(mf.manifest_of(image_of(JOB), STATUS, 100))
    exact = mf.MdRange(960, 960 + len(words) - 1)
    writes: list[tuple[int, list[int] | None]] = []

    def seen(code: int, address: int, values: list[int] | None) -> int | None:
        if code == 16:
            writes.append((address, values))
        return None

    face.interpose = seen
    on_device(face, lambda link: mf.write_manifest(link, exact, words, 0))
    assert mf.decode(held_words(face, exact)) == mf.decode(words)
    first = mf.MD_HOLDING_BASE + 2 * 960
    assert writes == [(first, [0, 0]), (first + 2, mf.to_registers(words[1:], 0)),
                      (first, mf.to_registers(words[:1], 0))]


def test_a_read_back_that_differs_is_refused() -> None:
    face = device()
    words = mf.encode(mf.manifest_of(image_of(JOB), STATUS, 100))

    def spoil(code: int, address: int, values: list[int] | None) -> int | None:
        if code == 3 and address == mf.MD_HOLDING_BASE + 2 * MD.first:
            face.controller.md.set_word(MD.first + 3, 12345)  # the flash time, changed
        return None

    face.interpose = spoil
    with pytest.raises(mf.ManifestError, match=r"^the manifest read back from MD960-MD1023 "
                                               r"differs from what was written$"):
        on_device(face, lambda link: mf.write_manifest(link, MD, words, 0))
