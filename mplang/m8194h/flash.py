"""`mpc flash` as a library call: download an image into one device and verify every program.

The device's own protocol (ET 6801-6835, appendix 12.1.12-12.1.13) decides the sequence. Per
program:

1. Read input register 100. A device left in MP or ISR download state (a download cut short,
   by us or by someone else) is sent the matching close frame and must read ready (0) again.
   If that close stored a truncated program in another slot, the slot is emptied (create +
   close) so that no half program can be called.
2. Create, every line, close: one FC16 at holding register 8000 per frame.
3. Read 100-114: ready again, registers 110/111 name this slot, 114 (download error) is 0.

Failures, and what is done about them:

- a Modbus exception 0x06 (busy), or ILLEGAL FUNCTION with cause 0xC1 (DPRAM full): the frame
  was refused, not stored; wait (growing pauses) and send the same frame again;
- any other exception: the device refused the frame. Register 102 gives the cause, reported
  in words at the source line of that frame; the download is closed and the slot emptied;
- a download error in 110-114 after the close: reported in words at the source line that
  holds the device's 0-based slot line;
- no answer, or a lost connection, during a frame: whether the device stored the frame is
  unknown, so the program is downloaded again from its create frame (step 1 closes the
  half-open download first), up to `retries` times. Reads are simply repeated (DeviceLink).

Success means every program was verified (or, flashing incrementally, recorded as already on
the device). `flash` returns a `FlashReport` with one `ProgramResult` per program whatever
happens; its `outcome` tells the CLI which exit code.

Incremental flashing (`FlashRecord`): after each verified program, a local record keeps the
program's content hash under the device's address, with the device's identity (input registers
81-85: module id and both firmware versions) and its download status (110-114) as the last
verification left it. The next run trusts the record only if identity, word order and download
status still match and the device is ready: any download by another tool since changes 110-114.
Then programs whose hash is recorded are not written. A program's entry is removed before its
download starts, so a cut-short download is never taken for a recorded one.

Fleets (`flash_fleet`): one `Flasher` per device, concurrently; devices that share a serial port
(one RS-485 bus) take turns, because one line carries one request at a time.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.m8194h.compiler import IMAGE_FORMAT, BuildResult
from mplang.m8194h.encode import Encoder
from mplang.m8194h.modbus import (
    MAX_WRITE_REGISTERS,
    DeviceException,
    DeviceLink,
    Endpoint,
    LinkError,
    LinkLost,
    LinkTimeout,
    backoff,
)

STATE_REGISTER = 100  # input: 0 ready, 1 MP download, 2 ISR download
CAUSE_REGISTER = 102  # input: cause of the last ILLEGAL FUNCTION
STATUS_FIRST, STATUS_COUNT = 110, 5  # input: MP no, ISR no, command, 0-based line, error
IDENTITY_FIRST, IDENTITY_COUNT = 81, 5  # input: module id, RSM firmware, i-8094H firmware
RECORD_FORMAT = "mpc-flash-record/1"
WORD_ORDER_REGISTER = 14  # holding: 0 MSW first, 1 LSW first
ILLEGAL_FUNCTION, DEVICE_BUSY = 0x01, 0x06
DPRAM_FULL = 0xC1  # register-102 cause that means "busy": the frame was not taken
STATES = {0: "ready", 1: "MP download", 2: "ISR download"}
CHIP_STATE_REGISTER = 101  # input: 4 loading the initial table, 5 initialization finished
CHIP_LOADING, CHIP_INITIALIZED = 4, 5
TRIGGER_REGISTER = 9  # holding: FRnet DI triggering 0 off / 1 on (5.4)
INIT_TIMEOUT_S = 2.0  # how long LOAD_INITIAL may take before the table counts unverified
INIT_POLL_S = 0.01
BUSY_PAUSE_FIRST_S, BUSY_PAUSE_MAX_S = 0.01, 0.5  # the FIFO drains in milliseconds

OUTCOMES = ("verified", "no-device", "rejected", "unverified", "interrupted")
"""`FlashReport.outcome`: every program verified; the device cannot be reached; the device
refused a program (or cannot take the image); the device did not confirm a download; the link
failed beyond the retries, the device stayed busy, or the run was cancelled."""


class ImageError(ValueError):
    """An image JSON that cannot be flashed; the message starts with the place."""


class Refused(Exception):
    """The device refused a frame (any Modbus exception but busy); `cause` is input register
    102 for ILLEGAL FUNCTION, else None."""

    def __init__(self, exception: DeviceException, cause: int | None, reason: str) -> None:
        super().__init__(reason)
        self.code = exception.code
        self.cause = cause


class FlashFailure(Exception):
    """Ends a flash run; `outcome` is one of OUTCOMES, `where` a source file:line or None."""

    def __init__(self, outcome: str, message: str, where: str | None = None) -> None:
        super().__init__(message)
        self.outcome = outcome
        self.where = where


# ------------------------------------------------------------------------------ the image
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
    text = path.read_bytes().decode("utf-8", errors="replace")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ImageError(f"{path}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}") from None
    return image_from_json(data, str(path), catalogue)


def render_plan(image: FlashImage, catalogue: Catalogue | None = None,
                recorded: frozenset[str] = frozenset()) -> str:
    """`mpc flash --dry-run`: every frame that would be written, in order, in hex, with the
    command name and the source line; nothing is sent. Programs in `recorded` (labels such as
    "MP3") are marked: the record says the device holds them, so a real run skips them if the
    device still matches the record."""
    catalogue = catalogue or catalogue_module.load()
    total = sum(len(p.frames) for p in image.programs)
    out = [f"; mpc flash --dry-run: {len(image.programs)} programs, {total} frames, FC16 at "
           f"holding register 8000, word order {image.word_order}"
           + (f", build {image.build_id}" if image.build_id else "")]
    for program in image.programs:
        out.append("")
        slot = f"{program.kind.upper()}{program.slot}"
        mark = "  [recorded on the device: skipped if it still matches]" \
            if slot in recorded else ""
        out.append(f"{program.label}  ({program.where(0) or 'source unknown'})  "
                   f"{len(program.frames)} frames{mark}")
        out += _plan_rows(program.frames, program.where, catalogue)
    if image.init is not None:
        init = image.init
        out.append("")
        out.append(f"INIT  ({init.where(0) or 'source unknown'})  {len(init.frames)} frames, "
                   f"then input register {CHIP_STATE_REGISTER} must read {CHIP_INITIALIZED}")
        out += _plan_rows(init.frames, init.where, catalogue)
    if image.triggers is not None:
        out.append("")
        out.append(f"TRIGGERS  write holding register {TRIGGER_REGISTER} = "
                   f"{int(image.triggers.enabled)} and read it back "
                   f"({len(image.triggers.entries)} channels; the table itself is entered "
                   "with EzMove)")
    return "\n".join(out) + "\n"


def _plan_rows(frames: list[list[int]], where: Callable[[int], str | None],
               catalogue: Catalogue) -> list[str]:
    """One dry-run line per frame: index, command, registers in hex, source place."""
    rows = []
    for index, frame in enumerate(frames):
        command = catalogue.by_code.get(frame[0])
        name = command.short_name if command is not None else "?"
        words = " ".join(f"{w:04X}" for w in frame)
        rows.append(f"  {index:>4}  {name:<20} {words:<44} {where(index) or ''}".rstrip())
    return rows


def plan_json(image: FlashImage, recorded: frozenset[str] = frozenset()) -> dict[str, object]:
    """`mpc flash --dry-run --json`: the same plan as data."""
    plan: dict[str, object] = {
        "dry_run": True, "word_order": image.word_order, "build_id": image.build_id,
        "programs": [{"kind": p.kind, "slot": p.slot, "name": p.name, "source": p.source,
                      "recorded": f"{p.kind.upper()}{p.slot}" in recorded,
                      "frame_lines": p.lines, "frames": p.frames}
                     for p in image.programs]}
    if image.init is not None:
        plan["init"] = {"source": image.init.source, "frame_lines": image.init.lines,
                        "frames": image.init.frames}
    if image.triggers is not None:
        plan["triggers"] = {"register": TRIGGER_REGISTER,
                            "value": int(image.triggers.enabled),
                            "entries": image.triggers.entries}
    return plan


# ------------------------------------------------------------------------- the record
def default_record_path() -> Path:
    """Without a project: the user's state directory (XDG), one record for every device."""
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "mpc" / "flash-record.json"


class FlashRecord:
    """What mpc last verified in which device: a JSON file, `{"format", "devices": {address:
    {"identity", "word_order", "last_status", "slots": {"MP3": {"hash", "name", "source",
    "build_id", "at"}}}}}`. Written (atomically) after every change, so an interrupted run
    keeps what it verified. A record that cannot be read is replaced, with a note: flashing
    everything is always correct, only slower."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.devices: dict[str, dict[str, Any]] = {}
        self.problem: str | None = None
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            self.problem = f"the flash record {path} cannot be read ({exc}): starting afresh"
            return
        devices = data.get("devices") if isinstance(data, dict) else None
        if not isinstance(data, dict) or data.get("format") != RECORD_FORMAT or \
                not isinstance(devices, dict):
            self.problem = f"{path} is not an mpc flash record: starting afresh"
            return
        self.devices = {key: entry for key, entry in devices.items()
                        if isinstance(entry, dict) and isinstance(entry.get("slots"), dict)}

    def entry(self, address: str) -> dict[str, Any] | None:
        return self.devices.get(address)

    def recorded_slots(self, address: str) -> frozenset[str]:
        entry = self.devices.get(address)
        return frozenset(entry["slots"]) if entry else frozenset()

    def save(self) -> None:
        """Write the file atomically (a crash leaves the old or the new record, never half)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps({"format": RECORD_FORMAT, "devices": self.devices}, indent=1,
                          sort_keys=True)
        handle, temporary = tempfile.mkstemp(prefix=".flash-record.", dir=self.path.parent)
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as out:
                out.write(text + "\n")
            os.replace(temporary, self.path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise


# ----------------------------------------------------------------------------- results
@dataclass
class ProgramResult:
    """What happened to one program. `status`: "verified"; "unchanged" (the record says the
    device holds exactly this program: nothing written); "rejected" (the device refused it);
    "unverified" (downloaded, not confirmed); "interrupted" (the link or the user cut the
    download); "pending" (never sent, because an earlier program failed)."""

    kind: str
    slot: int
    name: str | None
    source: str | None
    frames: int
    status: str = "pending"
    downloads: int = 0  # times the create frame was sent
    busy_waits: int = 0
    seconds: float = 0.0
    error: str | None = None
    where: str | None = None
    download_status: list[int] | None = None  # input registers 110-114 after the close

    @property
    def label(self) -> str:
        return f"{self.kind.upper()}{self.slot}" + (f" {self.name}" if self.name else "")

    def to_json(self) -> dict[str, object]:
        return {"kind": self.kind, "slot": self.slot, "name": self.name,
                "source": self.source, "frames": self.frames, "status": self.status,
                "downloads": self.downloads, "busy_waits": self.busy_waits,
                "seconds": round(self.seconds, 4), "error": self.error, "where": self.where,
                "download_status": self.download_status}


@dataclass
class StepResult:
    """The INIT download or the TRIGGERS enable: "pending", "verified", "rejected",
    "unverified" or "interrupted", with the error and its source place."""

    what: str  # "init" | "triggers"
    frames: int
    status: str = "pending"
    seconds: float = 0.0
    error: str | None = None
    where: str | None = None
    detail: str | None = None

    def to_json(self) -> dict[str, object]:
        return {"status": self.status, "frames": self.frames,
                "seconds": round(self.seconds, 4), "error": self.error, "where": self.where,
                "detail": self.detail}


@dataclass
class FlashReport:
    device: str
    word_order: int
    build_id: str | None
    programs: list[ProgramResult]
    init: StepResult | None = None
    triggers: StepResult | None = None
    outcome: str = "verified"
    error: str | None = None
    where: str | None = None
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    frames_planned: int = 0  # frames of the programs to write (known once connected)
    frames_written: int = 0  # frames the device accepted so far (progress displays poll it)

    @property
    def ok(self) -> bool:
        steps = [s for s in (self.init, self.triggers) if s is not None]
        return self.outcome == "verified" and all(p.status in ("verified", "unchanged")
                                                  for p in self.programs) \
            and all(s.status == "verified" for s in steps)

    def count(self, status: str) -> int:
        return sum(1 for p in self.programs if p.status == status)

    def to_json(self) -> dict[str, object]:
        return {"ok": self.ok, "outcome": self.outcome, "device": self.device,
                "word_order": self.word_order, "build_id": self.build_id,
                "error": self.error, "where": self.where, "notes": self.notes,
                "seconds": round(self.seconds, 4), "written": self.count("verified"),
                "unchanged": self.count("unchanged"), "frames_written": self.frames_written,
                "programs": [p.to_json() for p in self.programs],
                **({"init": self.init.to_json()} if self.init is not None else {}),
                **({"triggers": self.triggers.to_json()} if self.triggers is not None
                   else {})}


@dataclass(frozen=True)
class FlashOptions:
    set_word_order: bool = False
    """Write the image's word order to holding register 14 when the device's differs.
    Default: refuse, because the register changes how every client reads 32-bit values."""
    rebuild: Callable[[int], FlashImage] | None = None
    """Build the image again for the device's word order when it differs (sources given
    without an explicit word order); takes precedence over `set_word_order`."""
    busy_timeout: float = 10.0
    """Seconds one frame may keep meeting a busy device before flashing gives up."""
    record: FlashRecord | None = None
    """Flash incrementally against this record (None: write every program, record nothing)."""
    address: str | None = None
    """The device's key in the record [default: the endpoint's description]."""
    force: bool = False
    """Write every program even if the record says the device holds it (and record them)."""


def _results(image: FlashImage) -> list[ProgramResult]:
    return [ProgramResult(p.kind, p.slot, p.name, p.source, len(p.frames))
            for p in image.programs]


# ----------------------------------------------------------------------------- flashing
class Flasher:
    """One flash run over one `DeviceLink`. `report` is kept current, so a caller that
    cancels the run (Ctrl-C) still knows what was verified."""

    def __init__(self, image: FlashImage, link: DeviceLink,
                 options: FlashOptions = FlashOptions(),
                 progress: Callable[[str], None] | None = None,
                 catalogue: Catalogue | None = None) -> None:
        self.image = image
        self.link = link
        self.options = options
        self.progress = progress or (lambda _text: None)
        self.catalogue = catalogue or catalogue_module.load()
        self.profile = self.catalogue.profile
        self.report = FlashReport(link.endpoint.describe(), image.word_order, image.build_id,
                                  _results(image))
        self._set_steps()
        self._current: ProgramResult | StepResult | None = None
        self.address = options.address or link.endpoint.describe()
        self._entry: dict[str, Any] | None = None  # this device's record, once trusted

    def _set_steps(self) -> None:
        image = self.image
        self.report.init = None if image.init is None else StepResult(
            "init", len(image.init.frames))
        self.report.triggers = None if image.triggers is None else StepResult("triggers", 0)

    def _encoder(self) -> Encoder:
        """Create and close frames in the image's word order (a rebuild may change it)."""
        return Encoder(self.catalogue, self.image.word_order)

    def _note(self, text: str) -> None:
        self.report.notes.append(text)
        self.progress(f"note: {text}")

    async def run(self) -> FlashReport:
        start = time.monotonic()
        frames = sum(len(p.frames) for p in self.image.programs)
        self.progress(f"{self.report.device}: {len(self.image.programs)} program(s), "
                      f"{frames} frames")
        try:
            await self._connect()
            unchanged = await self._consult_record()
            self.report.frames_planned = sum(len(p.frames) for p in self.image.programs
                                             if p.slot_label not in unchanged) + (
                len(self.image.init.frames) if self.image.init is not None else 0)
            if unchanged:
                labels = [p.slot_label for p in self.image.programs
                          if p.slot_label in unchanged]
                self.progress(f"{len(labels)} program(s) unchanged since the recorded flash, "
                              f"not written: {', '.join(labels)}")
            for program, result in zip(self.image.programs, self.report.programs,
                                       strict=True):
                if program.slot_label in unchanged:
                    result.status = "unchanged"
                    continue
                self._current = result
                await self._program(program, result)
                self._current = None
            if self.image.init is not None and self.report.init is not None:
                self._current = self.report.init
                await self._init(self.image.init, self.report.init)
                self._current = None
            if self.image.triggers is not None and self.report.triggers is not None:
                self._current = self.report.triggers
                await self._triggers(self.image.triggers, self.report.triggers)
                self._current = None
        except FlashFailure as failure:
            self._fail(failure.outcome, str(failure), failure.where)
        except Refused as refusal:
            self._fail("rejected", f"the device refused a frame needed to make it ready: "
                       f"{refusal}")
        except DeviceException as exc:
            self._fail("rejected", f"the device refused a request: {exc}")
        except LinkError as exc:
            self._fail("interrupted", f"the link failed: {exc}")
        except asyncio.CancelledError:
            self._fail("interrupted", "interrupted before every program was verified")
            raise
        finally:
            self.link.close()
            self.report.seconds = time.monotonic() - start
        return self.report

    def _fail(self, outcome: str, message: str, where: str | None = None) -> None:
        self.report.outcome, self.report.error, self.report.where = outcome, message, where
        current = self._current
        if current is not None and current.status == "pending":
            current.status = {"rejected": "rejected", "unverified": "unverified"}.get(
                outcome, "interrupted")
            current.error, current.where = message, where

    # ---------------------------------------------------------------- connection
    async def _connect(self) -> None:
        """Open the link and settle the word order; any link failure here means there is
        no device to talk to."""
        try:
            await self.link.open()
            (device_order,) = await self.link.read_holding(WORD_ORDER_REGISTER, 1)
        except LinkError as exc:
            raise FlashFailure("no-device", str(exc)) from None
        except DeviceException as exc:
            raise FlashFailure("no-device", f"{self.link.endpoint.describe()} does not answer "
                               f"as an M8194H: reading holding register "
                               f"{WORD_ORDER_REGISTER} gives {exc}") from None
        wanted = self.image.word_order
        if device_order == wanted:
            return
        if self.options.rebuild is not None and device_order in (0, 1):
            self.image = self.options.rebuild(device_order)
            self.report.word_order = self.image.word_order
            self.report.build_id = self.image.build_id
            self.report.programs = _results(self.image)
            self._set_steps()
            self._note(f"the device's word order (holding register {WORD_ORDER_REGISTER}) is "
                       f"{device_order}: built for it")
            return
        if not self.options.set_word_order:
            raise FlashFailure("rejected", f"the device's word order (holding register "
                               f"{WORD_ORDER_REGISTER}) is {device_order}, the image's "
                               f"{wanted}: build with --word-order {device_order}, or let "
                               f"mpc flash set the device's with --set-word-order")
        await self.link.write_holding(WORD_ORDER_REGISTER, [wanted])
        (now,) = await self.link.read_holding(WORD_ORDER_REGISTER, 1)
        if now != wanted:
            raise FlashFailure("unverified", f"holding register {WORD_ORDER_REGISTER} reads "
                               f"{now} after writing {wanted}")
        self._note(f"set the device's word order (holding register {WORD_ORDER_REGISTER}) "
                   f"from {device_order} to {wanted}")

    # -------------------------------------------------------------------- record
    async def _consult_record(self) -> frozenset[str]:
        """The slots the device holds exactly as the image wants them, by the record; empty
        if there is no record, `force`, or the device no longer matches its record."""
        record = self.options.record
        if record is None:
            return frozenset()
        if record.problem:
            self._note(record.problem)
            record.problem = None
        identity = await self.link.read_input(IDENTITY_FIRST, IDENTITY_COUNT)
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        state, status = registers[0], registers[STATUS_FIRST - STATE_REGISTER:]
        old = record.entry(self.address)
        fresh: dict[str, Any] = {"identity": identity, "word_order": self.image.word_order,
                                 "last_status": status, "slots": {}}
        trusted = False
        if old is None:
            pass
        elif old.get("identity") != identity:
            self._note(f"the device at {self.address} is not the one recorded (module id and "
                       "firmware, input registers 81-85, differ): writing every program")
        elif old.get("word_order") != self.image.word_order:
            self._note("the word order changed since the recorded flash: writing every program")
        elif state != 0 or old.get("last_status") != status:
            self._note("the device's download status (input registers 110-114) changed since "
                       "the recorded flash (another download?): writing every program")
        else:
            trusted = True
            fresh["slots"] = dict(old["slots"])
        self._entry = fresh
        record.devices[self.address] = fresh
        record.save()
        if not trusted or self.options.force:
            return frozenset()
        slots = fresh["slots"]
        return frozenset(
            p.slot_label for p in self.image.programs
            if isinstance(slots.get(p.slot_label), dict)
            and slots[p.slot_label].get("hash") == p.content_hash(self.image.word_order))

    def _forget(self, slot_label: str) -> None:
        """Before a slot is written: the record may no longer vouch for it."""
        record = self.options.record
        if record is not None and self._entry is not None and \
                self._entry["slots"].pop(slot_label, None) is not None:
            record.save()

    def _remember(self, program: FlashProgram, status: list[int]) -> None:
        record = self.options.record
        if record is None or self._entry is None:
            return
        self._entry["slots"][program.slot_label] = {
            "hash": program.content_hash(self.image.word_order), "name": program.name,
            "source": program.source, "build_id": self.image.build_id,
            "at": datetime.now(UTC).isoformat(timespec="seconds")}
        self._entry["last_status"] = status
        record.save()

    # ------------------------------------------------------------------ programs
    async def _program(self, program: FlashProgram, result: ProgramResult) -> None:
        start = time.monotonic()
        failures = 0
        self._forget(program.slot_label)
        while True:
            try:
                await self._make_ready(program)
                result.downloads += 1
                for index in range(len(program.frames)):
                    await self._send(program, result, index)
                await self._verify(program, result)
                break
            except (LinkTimeout, LinkLost) as exc:
                failures += 1
                if failures > self.link.endpoint.retries:
                    await self._abandon(program)  # never leave a half download behind
                    raise FlashFailure("interrupted", f"{program.label}: {exc}; gave up after "
                                       f"{failures} downloads") from None
                self._note(f"{program.label}: {exc}: downloading it again from its create "
                           "frame")
                await asyncio.sleep(backoff(failures, self.link.endpoint.timeout))
        result.status = "verified"
        result.seconds = time.monotonic() - start
        if result.download_status is not None:
            self._remember(program, result.download_status)
        extra = [f"{result.downloads} downloads"] if result.downloads > 1 else []
        extra += [f"{result.busy_waits} busy waits"] if result.busy_waits else []
        self.progress(f"{program.label}: {len(program.frames)} frames verified "
                      f"({result.seconds * 1000:.0f} ms{', ' if extra else ''}"
                      f"{', '.join(extra)})")

    async def _make_ready(self, program: FlashProgram) -> None:
        """Bring a device left in a download state back to ready (step 1 of the module
        docstring)."""
        (state,) = await self.link.read_input(STATE_REGISTER, 1)
        if state == 0:
            return
        if state not in (1, 2):
            raise FlashFailure("rejected", f"input register {STATE_REGISTER} reads {state}, "
                               "not a state of the M8194H (0 ready, 1/2 MP/ISR download)")
        kind = "mp" if state == 1 else "isr"
        await self._write(self._encoder().close_frame(kind), None)
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        if registers[0] != 0:
            raise FlashFailure("rejected", f"the device stays in {STATES.get(registers[0])} "
                               "state after a close frame")
        mp_no, isr_no, _command, _line, error = registers[STATUS_FIRST - STATE_REGISTER:]
        slot = mp_no if kind == "mp" else isr_no
        self._note(f"the device was in {STATES[state]} state (a download cut short): closed "
                   f"it{f' ({kind.upper()}{slot})' if slot else ''}")
        if slot and error == 0 and (kind, slot) != (program.kind, program.slot):
            await self._empty(kind, slot)

    async def _empty(self, kind: str, slot: int) -> None:
        """Download an empty program into a slot a cut-short download left a truncated
        program in: an empty program returns at once when called, a truncated one may not."""
        encoder = self._encoder()
        self._forget(f"{kind.upper()}{slot}")
        await self._write(encoder.create_frame(kind, slot), None)
        await self._write(encoder.close_frame(kind), None)
        self._note(f"{kind.upper()}{slot} held a truncated program: emptied it")

    async def _write(self, frame: list[int], result: ProgramResult | None) -> None:
        """One frame; a busy device (exception 0x06, or cause 0xC1 DPRAM full) gets the same
        frame again after growing pauses. Any other refusal raises Refused, with the cause in
        words."""
        waited = 0.0
        attempt = 0
        while True:
            try:
                await self.link.write_frame(frame)
                return
            except DeviceException as exc:
                cause = None
                if exc.code == ILLEGAL_FUNCTION:
                    (cause,) = await self.link.read_input(CAUSE_REGISTER, 1)
                if exc.code != DEVICE_BUSY and cause != DPRAM_FULL:
                    reason = exc.name if cause is None else (
                        f"{exc.name}, cause {cause:#04x} ("
                        f"{self.profile.illegal_function_causes.get(cause, 'unknown cause')})")
                    raise Refused(exc, cause, reason) from None
                attempt += 1
                pause = backoff(attempt, BUSY_PAUSE_MAX_S, BUSY_PAUSE_FIRST_S)
                if waited + pause > self.options.busy_timeout:
                    raise FlashFailure("interrupted", f"the device stayed busy for "
                                       f"{waited:.1f} s") from None
                if result is not None:
                    result.busy_waits += 1
                await asyncio.sleep(pause)
                waited += pause

    async def _send(self, program: FlashProgram, result: ProgramResult, index: int) -> None:
        frame = program.frames[index]
        try:
            await self._write(frame, result)
            self.report.frames_written += 1
        except FlashFailure:  # the device stayed busy: close what was opened
            if index > 0:
                await self._abandon(program)
            raise
        except Refused as refusal:
            if index > 0:
                await self._abandon(program)
            raise FlashFailure("rejected", f"{program.label}: the device refused frame "
                               f"{index} ({self._describe(frame)}): {refusal}",
                               program.where(index)) from None

    async def _abandon(self, program: FlashProgram) -> None:
        """After a refused frame, or giving up on a program: end the download and empty the
        slot, so the device is ready and holds no truncated program. Failures here are noted,
        not raised: the refusal is what the user must see."""
        try:
            (state,) = await self.link.read_input(STATE_REGISTER, 1)
            if state in (1, 2):
                await self._write(self._encoder().close_frame("mp" if state == 1 else "isr"), None)
            await self._empty(program.kind, program.slot)
        except (LinkError, DeviceException, Refused, FlashFailure) as exc:
            self._note(f"{program.label}: could not tidy up after the refusal: {exc}")

    async def _verify(self, program: FlashProgram, result: ProgramResult) -> None:
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        state = registers[0]
        status = registers[STATUS_FIRST - STATE_REGISTER:]
        result.download_status = status
        mp_no, isr_no, command, line, error = status
        expected = (program.slot, 0) if program.kind == "mp" else (0, program.slot)
        if state != 0:
            raise FlashFailure("unverified", f"{program.label}: the device is in "
                               f"{STATES.get(state, state)} state after the close frame",
                               program.where(len(program.frames) - 1))
        if (mp_no, isr_no) != expected:
            raise FlashFailure("unverified", f"{program.label}: the download status "
                               f"(input registers 110-114) is for MP{mp_no}/ISR{isr_no}, "
                               "not for this program")
        if error:
            index = program.frame_at(line, self.catalogue)
            known = self.catalogue.by_code.get(command)
            name = known.short_name if known is not None else f"command {command:#06x}"
            reason = self.profile.download_errors.get(error, "unknown download error")
            raise FlashFailure("rejected", f"{program.label}: the device refused the program: "
                               f"download error {error:#04x} ({reason}) at slot line {line} "
                               f"({name})", program.where(index))

    # ------------------------------------------------------- initial table, triggers
    async def _init(self, init: FlashInit, result: StepResult) -> None:
        """Write the initial table (always: no register tells whether the device's table
        still matches a record), then wait for LOAD_INITIAL to finish: input register 101
        reads 4 while the table loads and 5 when the initialization finished (12.1.12)."""
        start = time.monotonic()
        for index, frame in enumerate(init.frames):
            try:
                await self._write(frame, None)
            except Refused as refusal:
                raise FlashFailure("rejected", f"INIT: the device refused frame {index} "
                                   f"({self._describe(frame)}): {refusal}",
                                   init.where(index)) from None
            self.report.frames_written += 1
        deadline = time.monotonic() + INIT_TIMEOUT_S
        while True:
            (state,) = await self.link.read_input(CHIP_STATE_REGISTER, 1)
            if state == CHIP_INITIALIZED:
                break
            if time.monotonic() > deadline:
                raise FlashFailure("unverified", f"INIT: input register {CHIP_STATE_REGISTER} "
                                   f"reads {state} {INIT_TIMEOUT_S:.0f} s after LOAD_INITIAL, "
                                   f"not {CHIP_INITIALIZED} (initialization finished)",
                                   init.where(len(init.frames) - 1))
            await asyncio.sleep(INIT_POLL_S)
        result.status = "verified"
        result.seconds = time.monotonic() - start
        result.detail = f"input register {CHIP_STATE_REGISTER} = {CHIP_INITIALIZED}"
        self.progress(f"INIT: {len(init.frames)} frames written, initial table loaded "
                      f"({result.seconds * 1000:.0f} ms)")

    async def _triggers(self, triggers: FlashTriggers, result: StepResult) -> None:
        """Switch FRnet DI triggering on (or off) and read the register back. The table
        itself cannot be downloaded: the manual sets it only through the vendor utility."""
        start = time.monotonic()
        wanted = int(triggers.enabled)
        where = f"{triggers.source}:{triggers.line}" if triggers.source else None
        try:
            await self.link.write_holding(TRIGGER_REGISTER, [wanted])
        except DeviceException as exc:
            raise FlashFailure("rejected", f"TRIGGERS: the device refused holding register "
                               f"{TRIGGER_REGISTER} = {wanted}: {exc}", where) from None
        (now,) = await self.link.read_holding(TRIGGER_REGISTER, 1)
        if now != wanted:
            raise FlashFailure("unverified", f"TRIGGERS: holding register {TRIGGER_REGISTER} "
                               f"reads {now} after writing {wanted}", where)
        result.status = "verified"
        result.seconds = time.monotonic() - start
        result.detail = f"holding register {TRIGGER_REGISTER} = {wanted}"
        state = "enabled" if wanted else "disabled"
        self.progress(f"TRIGGERS: FRnet DI triggering {state} (holding register "
                      f"{TRIGGER_REGISTER} reads {now})")
        self._note(f"the trigger table ({len(triggers.entries)} channels) is not downloadable: "
                   "enter it in EzMove (Setting -> FRnet DI..., Send Table) as "
                   "`mpc build --format triggers` lists it")

    def _describe(self, frame: list[int]) -> str:
        command = self.catalogue.by_code.get(frame[0])
        words = " ".join(f"{w:04X}" for w in frame)
        return f"{command.short_name} {words}" if command is not None else words


async def flash(image: FlashImage, endpoint: Endpoint, options: FlashOptions = FlashOptions(),
                progress: Callable[[str], None] | None = None) -> FlashReport:
    """Download every program of `image` into the device at `endpoint` and verify each."""
    return await Flasher(image, DeviceLink(endpoint), options, progress).run()


# -------------------------------------------------------------------------------- fleets
@dataclass
class FleetDevice:
    """One device of a fleet: its name (from the fleet file), image, endpoint and options."""

    name: str
    image: FlashImage
    endpoint: Endpoint
    options: FlashOptions = FlashOptions()


def _bus(endpoint: Endpoint) -> str | None:
    """Devices on the same serial port share one bus and must take turns."""
    return os.path.realpath(endpoint.serial) if endpoint.serial is not None else None


class Fleet:
    """Flash many devices at once: one Flasher per device, all started together, except that
    devices on one serial bus go one after another. A device that fails (or a bug met while
    flashing it) ends that device's run only. `flashers` exist from the start, so a display
    can poll their reports while `run` goes on."""

    def __init__(self, devices: Sequence[FleetDevice],
                 progress: Callable[[str, str], None] | None = None,
                 catalogue: Catalogue | None = None) -> None:
        catalogue = catalogue or catalogue_module.load()
        self.devices = list(devices)
        say: Callable[[str, str], None] = progress or (lambda _name, _text: None)

        def teller(name: str) -> Callable[[str], None]:
            return lambda text: say(name, text)

        self.flashers = [Flasher(device.image, DeviceLink(device.endpoint), device.options,
                                 teller(device.name), catalogue) for device in self.devices]

    @property
    def reports(self) -> list[FlashReport]:
        return [flasher.report for flasher in self.flashers]

    async def _one(self, flasher: Flasher) -> None:
        try:
            await flasher.run()
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a bug must not take the other devices down with it
            flasher.report.outcome = "interrupted"
            flasher.report.error = f"internal error in mpc: {type(exc).__name__}: {exc}"

    async def _in_turn(self, flashers: list[Flasher]) -> None:
        for flasher in flashers:
            await self._one(flasher)

    async def run(self) -> list[FlashReport]:
        lanes: dict[object, list[Flasher]] = {}
        for index, (device, flasher) in enumerate(zip(self.devices, self.flashers,
                                                      strict=True)):
            lanes.setdefault(_bus(device.endpoint) or index, []).append(flasher)
        tasks = [asyncio.ensure_future(self._in_turn(lane)) for lane in lanes.values()]
        try:
            await asyncio.gather(*tasks)
        except asyncio.CancelledError:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            for report in self.reports:
                if report.outcome == "verified" and not report.ok:
                    report.outcome = "interrupted"
                    report.error = report.error or "interrupted before this device was flashed"
            raise
        return self.reports


async def flash_fleet(devices: Sequence[FleetDevice],
                      progress: Callable[[str, str], None] | None = None) -> list[FlashReport]:
    """Flash every device of `devices` (see `Fleet`); one report per device, in order."""
    return await Fleet(devices, progress).run()
