"""The image a flash downloads: `FlashImage` and its programs, INIT block and TRIGGERS table,
made from a build (`image_from_build`) or read and checked from an image JSON (`load_image`,
`image_from_json`, raising `ImageError` that names the place). Kept apart from the download so
that `mpc disasm` and the dry run can read images without the device protocol.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mplang.family.face import BadImage
from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.lang.limits import read_json_file
from mplang.m8194h.compiler import IMAGE_FORMAT, BuildResult
from mplang.m8194h.encode import Encoder
from mplang.m8194h.modbus import MAX_WRITE_REGISTERS


class ImageError(BadImage):
    """An image JSON that cannot be flashed; the message starts with the place."""


@dataclass
class FlashProgram:
    """One program to download: its frames (create ... close) and, per frame, the source
    line it came from (None where unknown, e.g. an image written by another tool)."""

    kind: str
    slot: int
    name: str | None
    source: str | None
    frames: list[list[int]]
    lines: list[int | None]

    @property
    def label(self) -> str:
        return f"{self.kind.upper()}{self.slot}" + (f" {self.name}" if self.name else "")

    @property
    def slot_label(self) -> str:
        return f"{self.kind.upper()}{self.slot}"

    def content_hash(self, word_order: int) -> str:
        """What the device would hold: the same frames, the same hash."""
        text = json.dumps([word_order, self.kind, self.slot, self.frames])
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def where(self, index: int) -> str | None:
        """`file:line` of frame `index`, as far as the image knows it."""
        line = self.lines[index] if 0 <= index < len(self.lines) else None
        if self.source is None:
            return None
        return f"{self.source}:{line}" if line is not None else self.source

    def frame_at(self, slot_line: int, catalogue: Catalogue) -> int:
        """The index of the frame that occupies the device's 0-based `slot_line` (commands
        marked x2/x3/x4 take several lines); the close frame for lines past the last one."""
        first = 0
        for index in range(1, len(self.frames) - 1):
            command = catalogue.by_code.get(self.frames[index][0])
            cost = command.line_cost if command is not None else 1
            if first <= slot_line < first + cost:
                return index
            first += cost
        return len(self.frames) - 1


@dataclass
class FlashInit:
    """The INIT block: real-time frames writing the initial table (INITIAL_* axis codes),
    LOAD_INITIAL last; verified through the chip state (input register 101)."""

    source: str | None
    frames: list[list[int]]
    lines: list[int | None]

    def where(self, index: int) -> str | None:
        line = self.lines[index] if 0 <= index < len(self.lines) else None
        if self.source is None:
            return None
        return f"{self.source}:{line}" if line is not None else self.source


@dataclass
class FlashTriggers:
    """The TRIGGERS table: the device takes the table only from the vendor utility, so a
    flash enables (or disables) triggering at holding register 9 and reads it back."""

    enabled: bool
    entries: list[dict[str, Any]]
    source: str | None
    line: int | None


@dataclass
class FlashImage:
    word_order: int
    programs: list[FlashProgram]
    build_id: str | None = None
    init: FlashInit | None = None
    triggers: FlashTriggers | None = None


def image_from_build(build: BuildResult) -> FlashImage:
    """The download plan of a successful build, with every frame's source line."""
    if not build.ok:
        raise ValueError("a build with errors cannot be flashed")
    programs: list[FlashProgram] = []
    for p in build.programs:
        lines: list[int | None] = list(p.frame_lines)
        programs.append(FlashProgram(p.program.kind, p.placement.slot, p.program.name,
                                     p.program.source, [list(f) for f in p.frames], lines))
    init = None
    if build.init is not None:
        init = FlashInit(build.init.program.source, [list(f) for f in build.init.frames],
                         [line.span.line for line in build.init.program.lines])
    triggers = None
    if build.triggers is not None:
        triggers = FlashTriggers(build.triggers.enabled, list(build.triggers.entries),
                                 build.triggers.source, build.triggers.line)
    return FlashImage(build.word_order, programs, build.build_id(), init, triggers)


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def image_from_json(data: object, name: str, catalogue: Catalogue | None = None) -> FlashImage:
    """Check an image (spec section 2) as `mpc build` writes it and turn it into a download
    plan. Raises ImageError naming the place (`name: programs[2].frames[5][1]: ...`)."""
    catalogue = catalogue or catalogue_module.load()
    profile = catalogue.profile

    def fail(where: str, message: str) -> ImageError:
        return ImageError(f"{name}: {where}: {message}" if where else f"{name}: {message}")

    if not isinstance(data, dict):
        raise fail("", "an image is a JSON object")
    if data.get("format") != IMAGE_FORMAT:
        raise fail("format", f"expected \"{IMAGE_FORMAT}\", found {data.get('format')!r}")
    target = data.get("target")
    if not isinstance(target, dict) or target.get("word_order") not in (0, 1) \
            or not _is_int(target.get("word_order")):
        raise fail("target.word_order", "must be 0 or 1")
    word_order = int(target["word_order"])
    encoder = Encoder(catalogue, word_order)
    raw_programs = data.get("programs")
    if not isinstance(raw_programs, list) or not raw_programs:
        raise fail("programs", "must be a non-empty list of programs")
    build_id = data.get("build_id")
    programs: list[FlashProgram] = []
    seen: dict[tuple[str, int], int] = {}
    for n, raw in enumerate(raw_programs):
        at = f"programs[{n}]"
        if not isinstance(raw, dict):
            raise fail(at, "must be an object")
        kind, slot = raw.get("kind"), raw.get("slot")
        if not isinstance(kind, str) or kind not in ("mp", "isr"):
            raise fail(f"{at}.kind", f"must be \"mp\" or \"isr\", found {kind!r}")
        if not isinstance(slot, int) or isinstance(slot, bool) or \
                profile.budget(kind, slot) is None:
            raise fail(f"{at}.slot", f"{slot!r} is not a {kind.upper()} slot of the device")
        if (kind, slot) in seen:
            raise fail(at, f"{kind.upper()}{slot} is also programs[{seen[(kind, slot)]}]")
        seen[(kind, slot)] = n
        label = raw.get("name")
        source = raw.get("source")
        for key, value in (("name", label), ("source", source)):
            if value is not None and not isinstance(value, str):
                raise fail(f"{at}.{key}", "must be a string or null")
        frames = raw.get("frames")
        if not isinstance(frames, list) or len(frames) < 2:
            raise fail(f"{at}.frames", "must be a list of frames, create and close included")
        _check_frames(frames, f"{at}.frames", fail)
        create, close = encoder.create_frame(kind, slot), encoder.close_frame(kind)
        if frames[0] != create:
            raise fail(f"{at}.frames[0]", f"must be the create frame {create} of "
                       f"{kind.upper()}{slot}")
        if frames[-1] != close:
            raise fail(f"{at}.frames[{len(frames) - 1}]", f"must be the close frame {close}")
        for k in range(1, len(frames) - 1):
            if frames[k][0] == close[0]:
                # the rest would reach the device as real-time commands, and run
                raise fail(f"{at}.frames[{k}]", "a close frame before the last frame")
        lines = _frame_lines(raw.get("frame_lines"), len(frames), f"{at}.frame_lines", fail)
        programs.append(FlashProgram(kind, slot, label, source, frames, lines))
    return FlashImage(word_order, programs, build_id if isinstance(build_id, str) else None,
                      _init_from_json(data.get("init"), catalogue, fail),
                      _triggers_from_json(data.get("triggers"), fail))


def _frame_lines(lines: object, count: int, at: str, fail: Callable[[str, str], ImageError]
                 ) -> list[int | None]:
    """An image's "frame_lines": one source line (or null) per frame; absent: all unknown."""
    if lines is None:
        return [None] * count
    if not isinstance(lines, list) or len(lines) != count or \
            not all(v is None or (_is_int(v) and v > 0) for v in lines):
        raise fail(at, "must list one source line (or null) per frame")
    return lines


def _check_frames(frames: object, at: str, fail: Callable[[str, str], ImageError]) -> None:
    """Every frame a list of 1..MAX_WRITE_REGISTERS 16-bit register values."""
    if not isinstance(frames, list) or not frames:
        raise fail(at, "must be a non-empty list of frames")
    for k, frame in enumerate(frames):
        where = f"{at}[{k}]"
        if not isinstance(frame, list) or not 1 <= len(frame) <= MAX_WRITE_REGISTERS:
            raise fail(where, f"must be a list of 1..{MAX_WRITE_REGISTERS} registers")
        for w, word in enumerate(frame):
            if not _is_int(word) or not 0 <= word <= 0xFFFF:
                raise fail(f"{where}[{w}]", f"{word!r} is not a 16-bit register value")


def _init_from_json(raw: object, catalogue: Catalogue, fail: Callable[[str, str], ImageError]
                    ) -> FlashInit | None:
    """The image's "init": initial-table commands (IT scope, an INITIAL_* axis code), then
    LOAD_INITIAL and nothing after it; anything else would change live settings or run."""
    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise fail("init", "must be an object")
    frames = raw.get("frames")
    _check_frames(frames, "init.frames", fail)
    assert isinstance(frames, list)
    load = catalogue.rtc_by_short["LOAD_INITIAL"].code
    offset = int(catalogue.profile.raw["axes"]["initial_table_offset"])
    for k, frame in enumerate(frames[:-1]):
        command = catalogue.by_code.get(frame[0])
        if command is None or "it" not in command.scope:
            raise fail(f"init.frames[{k}]", f"{frame[0]:#06x} is not a command that writes "
                       "the initial table")
        if len(frame) < 2 or not frame[1] & offset:
            raise fail(f"init.frames[{k}][1]", "must be an INITIAL_* axis code (0x11..0x1F)")
    if frames[-1] != [load]:
        raise fail(f"init.frames[{len(frames) - 1}]", f"must be LOAD_INITIAL [{load}]")
    source = raw.get("source")
    if source is not None and not isinstance(source, str):
        raise fail("init.source", "must be a string or null")
    return FlashInit(source, frames,
                     _frame_lines(raw.get("frame_lines"), len(frames), "init.frame_lines", fail))


def _triggers_from_json(raw: object, fail: Callable[[str, str], ImageError]
                        ) -> FlashTriggers | None:
    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise fail("triggers", "must be an object")
    enabled = raw.get("enabled")
    if not isinstance(enabled, bool):
        raise fail("triggers.enabled", "must be true or false")
    entries = raw.get("entries")
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise fail("triggers.entries", "must be a list of objects")
    source, line = raw.get("source"), raw.get("line")
    if source is not None and not isinstance(source, str):
        raise fail("triggers.source", "must be a string or null")
    if line is not None and not _is_int(line):
        raise fail("triggers.line", "must be a line number or null")
    return FlashTriggers(enabled, entries, source, line)


def load_image(path: Path, catalogue: Catalogue | None = None) -> FlashImage:
    """Read and check an image JSON file. OSError if unreadable, ImageError if not an image."""
    try:
        data = read_json_file(path)
    except json.JSONDecodeError as exc:
        raise ImageError(f"{path}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}") from None
    except ValueError as exc:  # nested too deep, or a number Python will not convert
        raise ImageError(f"{path}: not an image: {exc}") from None
    return image_from_json(data, str(path), catalogue)
