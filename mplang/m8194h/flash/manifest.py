"""The build manifest `mpc flash` stores in the device's machine data (manual 3.19: MD0..MD1023
are non-volatile 32-bit longs at holding registers 3000 + 2n), because the M8194H cannot read
a stored macro program back: without it only the computer that flashed a device knows what it
holds. `encode` and `decode` are the layout (docs/flash.md, "The build manifest"), kept apart
from the Modbus reads and writes (`read_manifest`, `write_manifest`) so other tools and the
tests can use it without a device.

Layout, one 32-bit MD word after the other from the first MD of the range:

    0  magic "MPCM" (0x4D50434D)
    1  format version (high 16 bits) | words used, this header included (low 16 bits)
    2  CRC-32 of words 1 and 3.. (each big-endian), so a half-written manifest shows
    3  flash time, Unix seconds (UTC)
    4  input register 110 (high) | 111 (low): the download status the last verification read
    5  input register 112 (high) | 113 (low)
    6  input register 114 (high 16) | word order (bits 8-15) | number of programs (bits 0-7)
    7.. bytes, big-endian in each word, zero-padded: build id and tool version (each a length
       byte and UTF-8), then per program: slot (2 bytes: bit 15 set for an ISR), the first 8
       bytes of its frame hash, its name (a length byte, at most 12 bytes of UTF-8)

A writer invalidates word 0 first, writes words 1.. and word 0 last, so a manifest cut short
has no magic or fails its CRC.
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field

from mplang import __version__
from mplang.m8194h.encode import join32, split32
from mplang.m8194h.flash.image import FlashImage
from mplang.m8194h.modbus import DeviceLink

MAGIC = 0x4D50434D  # "MPCM"
VERSION = 1
HEADER_WORDS = 7
NAME_BYTES = 12  # a program's name is cut to this many bytes of UTF-8
HASH_BYTES = 8
TEXT_BYTES = 40  # build id and tool version are cut to this many bytes
MD_HOLDING_BASE = 3000  # holding register of MD0 (3000 + 2n)
LONG_MDS = 1024  # MD0..MD1023 are longs; the floats above may not keep every bit pattern
DEFAULT_RANGE = "MD768-MD1023"
MAX_PER_WRITE = 61  # MDs per FC16 (123 registers at most)
RANGE_TEXT = re.compile(r"^\s*MD(\d{1,4})\s*-\s*MD(\d{1,4})\s*$", re.IGNORECASE)


class ManifestError(ValueError):
    """MD words that are not a complete manifest; the message says why."""


@dataclass(frozen=True)
class ManifestProgram:
    kind: str  # "mp" or "isr"
    slot: int
    hash: str  # 16 hex digits: the start of `FlashProgram.content_hash`
    name: str

    @property
    def slot_label(self) -> str:
        return f"{self.kind.upper()}{self.slot}"


@dataclass(frozen=True)
class Manifest:
    build_id: str
    tool_version: str
    flashed_at: int  # Unix seconds
    word_order: int
    status: tuple[int, int, int, int, int]  # input registers 110-114
    programs: tuple[ManifestProgram, ...] = field(default_factory=tuple)

    def by_slot(self) -> dict[str, ManifestProgram]:
        return {p.slot_label: p for p in self.programs}

    def same_content(self, other: Manifest) -> bool:
        """Everything but the flash time: rewriting such a manifest would only wear MD."""
        return (self.build_id, self.tool_version, self.word_order, self.status,
                self.programs) == (other.build_id, other.tool_version, other.word_order,
                                   other.status, other.programs)


@dataclass(frozen=True)
class MdRange:
    first: int
    last: int

    @property
    def count(self) -> int:
        return self.last - self.first + 1

    def __str__(self) -> str:
        return f"MD{self.first}-MD{self.last}"


def parse_range(text: str) -> MdRange:
    """`MDa-MDb` (a <= b, both long MDs, room for the header): ValueError says what is wrong."""
    match = RANGE_TEXT.match(text)
    if match is None:
        raise ValueError(f"{text!r} is not a machine-data range: write MDa-MDb, e.g. "
                         f"{DEFAULT_RANGE}")
    first, last = int(match[1]), int(match[2])
    if first > last:
        raise ValueError(f"{text}: MD{first} comes after MD{last}")
    if last >= LONG_MDS:
        raise ValueError(f"{text}: the manifest goes in the long machine data MD0-MD1023 "
                         "(MD1024-MD2047 are floats, whose bit patterns a device may change)")
    if last - first + 1 < HEADER_WORDS + 1:
        raise ValueError(f"{text}: a manifest needs at least {HEADER_WORDS + 1} MD")
    return MdRange(first, last)


def _text(value: str) -> bytes:
    raw = value.encode("utf-8")[:TEXT_BYTES]
    return bytes([len(raw)]) + raw


def _name(value: str) -> bytes:
    return counted(value, NAME_BYTES)


def counted(value: str, limit: int) -> bytes:
    """A length byte and at most `limit` bytes of `value` in UTF-8, never cutting a
    character in half (also the host name of a download lease)."""
    raw = value.encode("utf-8")[:limit]
    while raw:
        try:
            raw.decode("utf-8")
            break
        except UnicodeDecodeError:
            raw = raw[:-1]
    return bytes([len(raw)]) + raw


def encode(manifest: Manifest) -> list[int]:
    """The MD words of `manifest` (unsigned 32-bit), checksum included."""
    if len(manifest.programs) > 255:
        raise ValueError("a manifest lists at most 255 programs")
    body = bytearray(_text(manifest.build_id) + _text(manifest.tool_version))
    for program in manifest.programs:
        slot = program.slot | (0x8000 if program.kind == "isr" else 0)
        body += slot.to_bytes(2, "big") + bytes.fromhex(program.hash[:HASH_BYTES * 2])
        body += _name(program.name)
    body += bytes(-len(body) % 4)
    tail = [int.from_bytes(body[i:i + 4], "big") for i in range(0, len(body), 4)]
    total = HEADER_WORDS + len(tail)
    s = manifest.status
    words = [MAGIC, (VERSION << 16) | total, 0, manifest.flashed_at & 0xFFFFFFFF,
             (s[0] << 16) | s[1], (s[2] << 16) | s[3],
             (s[4] << 16) | (manifest.word_order << 8) | len(manifest.programs), *tail]
    words[2] = _crc(words)
    return words


def _crc(words: Sequence[int]) -> int:
    data = b"".join(w.to_bytes(4, "big") for i, w in enumerate(words) if i not in (0, 2))
    return zlib.crc32(data) & 0xFFFFFFFF


def decode(words: Sequence[int]) -> Manifest:
    """The manifest in `words` (the MD range, from its first MD), or ManifestError: no
    manifest, another format version, or a half-written one (the checksum fails)."""
    if len(words) < HEADER_WORDS or words[0] != MAGIC:
        raise ManifestError("no manifest (the first MD of the range is not \"MPCM\")")
    version, total = words[1] >> 16, words[1] & 0xFFFF
    if version != VERSION:
        raise ManifestError(f"manifest format version {version}, this mpc reads {VERSION}")
    if not HEADER_WORDS <= total <= len(words):
        raise ManifestError(f"the manifest claims {total} MD, the range holds {len(words)}")
    used = list(words[:total])
    if _crc(used) != words[2]:
        raise ManifestError("the manifest's checksum fails: it was cut short while being "
                            "written, or something else wrote into its MD range")
    status = (used[4] >> 16, used[4] & 0xFFFF, used[5] >> 16, used[5] & 0xFFFF, used[6] >> 16)
    count = used[6] & 0xFF
    body = b"".join(w.to_bytes(4, "big") for w in used[HEADER_WORDS:])
    try:
        at = 0
        texts = []
        for _ in range(2):
            length = body[at]
            texts.append(body[at + 1:at + 1 + length].decode("utf-8"))
            at += 1 + length
        programs = []
        for _ in range(count):
            slot = int.from_bytes(body[at:at + 2], "big")
            digest = body[at + 2:at + 2 + HASH_BYTES].hex()
            length = body[at + 2 + HASH_BYTES]
            start = at + 3 + HASH_BYTES
            name = body[start:start + length].decode("utf-8")
            if len(digest) != HASH_BYTES * 2 or start + length > len(body):
                raise IndexError
            programs.append(ManifestProgram("isr" if slot & 0x8000 else "mp", slot & 0x7FFF,
                                            digest, name))
            at = start + length
    except (IndexError, UnicodeDecodeError):
        raise ManifestError("the manifest's contents do not fit its layout") from None
    return Manifest(texts[0], texts[1], used[3], (used[6] >> 8) & 0xFF, status,
                    tuple(programs))


def to_registers(words: Sequence[int], word_order: int) -> list[int]:
    """MD words as holding registers, in the device's word order (holding register 14)."""
    return [half for word in words for half in split32(word, word_order)]


def from_registers(registers: Sequence[int], word_order: int) -> list[int]:
    return [join32(list(registers[i:i + 2]), word_order, signed=False)
            for i in range(0, len(registers) - 1, 2)]


def to_json(manifest: Manifest) -> dict[str, object]:
    """For `mpc status --json` and the flash report."""
    return {"format_version": VERSION, "build_id": manifest.build_id,
            "tool_version": manifest.tool_version, "flashed_at": manifest.flashed_at,
            "word_order": manifest.word_order, "download_status": list(manifest.status),
            "programs": [{"slot": p.slot_label, "name": p.name, "hash": p.hash}
                         for p in manifest.programs]}


async def read_words(link: DeviceLink, md: MdRange, word_order: int) -> list[int]:
    """The raw words of the MD range, read in FC3 requests of at most 61 MD."""
    words: list[int] = []
    for first in range(md.first, md.last + 1, MAX_PER_WRITE):
        count = min(MAX_PER_WRITE, md.last + 1 - first)
        registers = await link.read_holding(MD_HOLDING_BASE + 2 * first, 2 * count)
        words += from_registers(registers, word_order)
    return words


async def read_manifest(link: DeviceLink, md: MdRange, word_order: int) -> Manifest:
    """The device's manifest, or ManifestError (none, or not a complete one)."""
    return decode(await read_words(link, md, word_order))


async def invalidate(link: DeviceLink, md: MdRange, word_order: int) -> None:
    """Clear the magic word: from here on the device holds no manifest to trust (a flash is
    about to change programs)."""
    await link.write_holding(MD_HOLDING_BASE + 2 * md.first, split32(0, word_order))


async def write_manifest(link: DeviceLink, md: MdRange, words: Sequence[int],
                         word_order: int) -> None:
    """Write `words` at the start of the range (magic word last, after clearing it first),
    then read them back: ManifestError if the device holds anything else. MD outside the
    range are never written, nor the unused rest of the range."""
    if len(words) > md.count:
        raise ManifestError(f"the manifest needs {len(words)} MD, {md} holds {md.count}")
    await invalidate(link, md, word_order)
    for offset in range(1, len(words), MAX_PER_WRITE):
        chunk = list(words[offset:offset + MAX_PER_WRITE])
        await link.write_holding(MD_HOLDING_BASE + 2 * (md.first + offset),
                                 to_registers(chunk, word_order))
    await link.write_holding(MD_HOLDING_BASE + 2 * md.first, split32(words[0], word_order))
    back = await read_words(link, MdRange(md.first, md.first + len(words) - 1), word_order)
    if back != list(words):
        raise ManifestError(f"the manifest read back from {md} differs from what was written")


def manifest_of(image: FlashImage, status: Sequence[int], flashed_at: int,
                tool_version: str = __version__) -> Manifest:
    """The manifest of `image` as the device holds it after a flash that left download
    status `status` (input registers 110-114)."""
    s0, s1, s2, s3, s4 = (int(v) & 0xFFFF for v in status)
    return Manifest(image.build_id or "", tool_version, flashed_at, image.word_order,
                    (s0, s1, s2, s3, s4), tuple(
                        ManifestProgram(p.kind, p.slot, p.content_hash(image.word_order)
                                        [:HASH_BYTES * 2], p.name or "")
                        for p in image.programs))


def check_room(image: FlashImage, md: MdRange) -> None:
    """ManifestError if the image's manifest does not fit the range (before anything is
    written), saying how many MD it needs."""
    needed = len(encode(manifest_of(image, (0, 0, 0, 0, 0), 0)))
    first = max(0, md.last + 1 - needed)
    if needed > md.count:
        raise ManifestError(f"the build manifest of {len(image.programs)} program(s) needs "
                            f"{needed} MD, and the identity range {md} holds {md.count}: "
                            f"give a larger one (--identity MD{first}-MD{md.last}"
                            " or [flash] identity), or --no-identity")


def matching_slots(manifest: Manifest, image: FlashImage) -> frozenset[str]:
    """The image's slots whose frames the manifest names by the same hash."""
    held = manifest.by_slot()
    return frozenset(
        p.slot_label for p in image.programs
        if p.slot_label in held
        and held[p.slot_label].hash == p.content_hash(image.word_order)[:HASH_BYTES * 2])


async def store(link: DeviceLink, md: MdRange, image: FlashImage, status: Sequence[int],
                flashed_at: int) -> tuple[Manifest, bool]:
    """Write the image's manifest with download status `status` unless the device holds the
    same one apart from the time (MD are non-volatile memory: no needless writes). The
    manifest the device holds afterwards, and whether it was written."""
    wanted = manifest_of(image, status, flashed_at)
    try:
        held: Manifest | None = await read_manifest(link, md, image.word_order)
    except ManifestError:
        held = None
    if held is not None and held.same_content(wanted):
        return held, False
    await write_manifest(link, md, encode(wanted), image.word_order)
    return wanted, True


async def vouched(link: DeviceLink, md: MdRange, image: FlashImage, state: int,
                  status: Sequence[int]) -> frozenset[str] | str:
    """The image's slots the device's manifest vouches for, or why it vouches for none: it
    must be complete, for this word order, and the device ready with exactly the download
    status (input registers 110-114) the manifest recorded (any download since changes
    them). "" when the device holds no manifest at all (a first flash: nothing to say)."""
    try:
        manifest = await read_manifest(link, md, image.word_order)
    except ManifestError as exc:
        return "" if str(exc).startswith("no manifest") else str(exc)
    if manifest.word_order != image.word_order:
        return "the device's build manifest is for another word order"
    if state != 0 or list(manifest.status) != list(status):
        return ("the device's download status (input registers 110-114) changed since its "
                "build manifest was written")
    return matching_slots(manifest, image)
