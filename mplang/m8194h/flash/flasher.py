"""Download an image into one device and verify every program: `Flasher` runs the download
over one `DeviceLink`, `flash` is the library call.

The device's own protocol (ET 6801-6835, appendix 12.1.12-12.1.13) decides the sequence. Per
program:

1. Read input register 100. A device left in MP or ISR download state (a download cut short,
   by us or by someone else) is sent the matching close frame and must read ready (0) again.
   If that close stored a truncated program in another slot, the slot is emptied (create +
   close) so that no half program can be called.
2. Create, every line, close: one FC16 at holding register 8000 per frame. Over RTU a
   read of register 100 goes between two frames of one length (`_separate`).
3. Read 100-114: ready again, registers 110/111 name this slot, 114 (download error) is 0.

Failures, and what is done about them:

- a Modbus exception 0x06 (busy), or ILLEGAL FUNCTION with cause 0xC1 (DPRAM full): the frame
  was refused, not stored; wait (growing pauses) and send the same frame again;
- any other exception: the device refused the frame. Register 102 gives the cause, reported
  in words at the source line of that frame; the download is closed and the slot emptied;
- a download error in 110-114 after the close: reported in words at the source line that
  holds the device's 0-based slot line;
- no answer, or a lost connection, during a frame: whether the device stored the frame is
  unknown, and it may still reach the device later. The link is fenced first (a barrier
  read on the same connection, or a fresh connection and a quiet period in which the
  device's registers 100-119 must not change), then the program is downloaded again from
  its create frame (step 1 closes the half-open download first), up to `retries` times.
  Reads are simply repeated (DeviceLink);
- an answer no request of the download was waiting for (a duplicated or delayed request,
  seen by the link): the device may hold a line twice, so the program is downloaded again;
- a refused create frame while the device is in a download this flash did not open, or a
  refused line after someone closed the download: another client is downloading. It is
  named, and nothing is tidied up (that would destroy the other client's program);
- giving up on a program: the tidy-up closes the download and empties the slot, retried
  with growing pauses; if it cannot, the failure says what the slot may hold and how to
  repair it (`tidy`).

`FlashOptions` holds the choices of a run: word order, incremental record, busy timeout.

`Flasher` is one file because it is one state machine: every step reads and changes the same
download state (whether the link is settled, the program under way, the lease, the report),
and the order of its methods is the protocol's; spread over modules it would be read out of
order. The lease itself (`lease`), the record, the manifest and the report live apart.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.m8194h.encode import Encoder
from mplang.m8194h.flash import manifest as manifests
from mplang.m8194h.flash.image import FlashImage, FlashInit, FlashProgram, FlashTriggers
from mplang.m8194h.flash.lease import Lease, LeaseHeld, LeaseSettings
from mplang.m8194h.flash.record import FlashRecord
from mplang.m8194h.flash.registers import (
    CALL_REGISTER,
    CAUSE_REGISTER,
    CHIP_INITIALIZED,
    CHIP_STATE_REGISTER,
    DEVICE_BUSY,
    DPRAM_FULL,
    IDENTITY_COUNT,
    IDENTITY_FIRST,
    ILLEGAL_FUNCTION,
    MACRO_RUNNING,
    STATE_REGISTER,
    STATE_SPAN,
    STATUS_COUNT,
    STATUS_FIRST,
    TRIGGER_REGISTER,
    WORD_ORDER_REGISTER,
    state_name,
)
from mplang.m8194h.flash.report import (
    FlashFailure,
    FlashReport,
    OtherClient,
    ProgramResult,
    Refused,
    StepResult,
)
from mplang.m8194h.modbus import (
    DeviceException,
    DeviceLink,
    Endpoint,
    LinkError,
    LinkLost,
    LinkTimeout,
    backoff,
)

INIT_TIMEOUT_S = 2.0  # how long LOAD_INITIAL may take before the table counts unverified
INIT_POLL_S = 0.01
BUSY_PAUSE_FIRST_S, BUSY_PAUSE_MAX_S = 0.01, 0.5  # the FIFO drains in milliseconds
TIDY_ATTEMPTS = 8  # tidy-up rounds after giving up on a program (growing pauses, ~5 s)
TIDY_PAUSE_FIRST_S, TIDY_PAUSE_MAX_S = 0.05, 1.0
QUIET_TIMEOUTS = 3  # a quiet period lasts this many answer timeouts
QUIET_ROUNDS = 3  # quiet periods tried before the device counts as busy with another client


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
    stop_running: bool = False
    """Stop a running macro program (RTC MP_TERMINATE) before writing. Default: refuse
    before anything is written and name the program that runs (holding register 8)."""
    identity: manifests.MdRange | None = None
    """Where the build manifest goes in machine data (None: never touch MD). Written after
    everything verified; invalidated before the first program is written."""
    lease: LeaseSettings | None = None
    """Take the device's download lease (`lease`) before writing anything, check it before
    each program and at the end, give it back when done (None: no lease, as a library call
    that serialises its own clients may choose; `mpc flash` always takes it)."""
    wait_lease: float = 0.0
    """Seconds to wait for another client's lease to end before giving up ("leased")."""


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
        self._opened: tuple[str, int] | None = None  # a download this flash may have open
        self._accepted = 0  # line frames of the current download the device accepted
        self._unanswered = 0  # 1 if the last frame sent got no answer
        self._last_status: list[int] | None = None  # 110-114 at the last verification
        self._unsaved = False  # the record holds verified programs not written to its file
        self._lease: Lease | None = None  # this flash's lease, once taken

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
            if self.options.identity is not None:
                try:
                    manifests.check_room(self.image, self.options.identity)
                except manifests.ManifestError as exc:
                    raise FlashFailure("rejected", f"nothing was written: {exc}") from None
                lease = self.options.lease
                if lease is not None and lease.overlaps(self.options.identity):
                    raise FlashFailure("rejected", f"nothing was written: the identity range "
                                       f"{self.options.identity} overlaps the download lease "
                                       f"{lease.md} ([flash_lease] range of the device "
                                       "profile): give another --identity")
            await self._connect()
            await self._take_lease()
            unchanged = await self._consult_record()
            self.report.frames_planned = sum(len(p.frames) for p in self.image.programs
                                             if p.slot_label not in unchanged) + (
                len(self.image.init.frames) if self.image.init is not None else 0)
            if unchanged:
                labels = [p.slot_label for p in self.image.programs
                          if p.slot_label in unchanged]
                self.progress(f"{len(labels)} program(s) unchanged since the recorded flash, "
                              f"not written: {', '.join(labels)}")
            if self.report.frames_planned:
                await self._check_running()
            identity = self.options.identity
            if identity is not None and any(p.slot_label not in unchanged
                                            for p in self.image.programs):
                await manifests.invalidate(self.link, identity, self.image.word_order)
            for program, result in zip(self.image.programs, self.report.programs,
                                       strict=True):
                if program.slot_label in unchanged:
                    result.status = "unchanged"
                    continue
                await self._check_lease(program.label)
                self._current = result
                await self._program(program, result)
                self._current = None
            if any(p.status == "verified" for p in self.report.programs):
                await self._final_check()
            if self.image.init is not None and self.report.init is not None:
                self._current = self.report.init
                await self._init(self.image.init, self.report.init)
                self._current = None
            if self.image.triggers is not None and self.report.triggers is not None:
                self._current = self.report.triggers
                await self._triggers(self.image.triggers, self.report.triggers)
                self._current = None
            if identity is not None:
                await self._store_manifest(identity)
            await self._check_lease("the end of the flash (the programs above verified, but "
                                    "the other client may have changed them since)")
        except OtherClient as failure:
            self._fail(failure.outcome, f"{failure}{await self._name_other()}", failure.where)
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
            await self._release_lease()
            self.link.close()
            if self.options.record is not None and self._unsaved:  # what was verified:
                self._unsaved = False  # saved once, at the end (`FlashRecord.start_run`)
                self.options.record.save()
            self.report.seconds = time.monotonic() - start
        return self.report

    # --------------------------------------------------------------------- lease
    async def _take_lease(self) -> None:
        """Before anything is written: hold the device's download lease (waiting up to
        `wait_lease` for another client's); "leased" names the holder otherwise."""
        settings = self.options.lease
        if settings is None or self._lease is not None:
            return
        self._lease = Lease(self.link, settings, self.image.word_order,
                            self.options.wait_lease, self.progress)
        try:
            await self._lease.take()
        except LeaseHeld as exc:
            raise FlashFailure("leased", str(exc)) from None

    async def _check_lease(self, before: str) -> None:
        if self._lease is None:
            return
        self._lease.word_order = self.image.word_order
        try:
            await self._lease.check(before)
        except LeaseHeld as exc:
            raise FlashFailure("leased", str(exc)) from None

    async def _release_lease(self) -> None:
        """Give the lease back, on success and on any failure the link still carries; one
        the link cannot give back expires by itself."""
        if self._lease is None or self._lease.mine is None:
            return
        try:
            await asyncio.wait_for(self._lease.release(),
                                   4 * self.link.endpoint.timeout + 1.0)
        except (LinkError, DeviceException, TimeoutError) as exc:
            self._note(f"the device's download lease was not given back ({exc}): it expires "
                       f"{self._lease.seconds} s after its last renewal")

    async def _name_other(self) -> str:
        """The other client a download clash shows, by the device's lease where it holds
        one; else that it ignores the lease."""
        if self._lease is None:
            return ""
        try:
            other = await self._lease.other()
        except (LinkError, DeviceException):
            return ""
        if other is None:
            return " (it holds no download lease: an older mpc, or another tool)"
        return f" (the device's download lease names {other})"

    def _fail(self, outcome: str, message: str, where: str | None = None) -> None:
        self.report.outcome, self.report.error, self.report.where = outcome, message, where
        current = self._current
        if current is not None and current.status == "pending":
            current.status = {"rejected": "rejected", "unverified": "unverified"}.get(
                outcome, "interrupted")
            current.error, current.where = message, where

    async def _store_manifest(self, identity: manifests.MdRange) -> None:
        """After every program verified: the build manifest with the download status the
        device shows now, written and read back (`manifest.store`)."""
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        if registers[0] != 0:
            raise FlashFailure("unverified", f"the device is in {state_name(registers[0])} "
                               "state after the last program: no manifest written")
        try:
            held, written = await manifests.store(
                self.link, identity, self.image, registers[STATUS_FIRST - STATE_REGISTER:],
                int(time.time()))
        except manifests.ManifestError as exc:
            raise FlashFailure("unverified", str(exc)) from None
        self.report.manifest = manifests.to_json(held)
        if written:
            self.progress(f"build manifest written to {identity} and read back")

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
        await self._take_lease()  # the first write: the lease comes before it
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
        if not trusted and self.options.identity is not None and not self.options.force:
            found = await manifests.vouched(self.link, self.options.identity, self.image,
                                            state, status)
            if isinstance(found, str):
                if found:
                    self._note(f"{found}: not trusted")
            else:
                trusted = True
                fresh["slots"] = {p.slot_label: {
                    "hash": p.content_hash(self.image.word_order), "name": p.name,
                    "source": p.source, "build_id": None, "at": None}
                    for p in self.image.programs if p.slot_label in found}
                self._note(f"trusting the device's build manifest ({len(found)} program(s) "
                           "match)")
        slots = fresh["slots"]
        unchanged = frozenset() if not trusted or self.options.force else frozenset(
            p.slot_label for p in self.image.programs
            if isinstance(slots.get(p.slot_label), dict)
            and slots[p.slot_label].get("hash") == p.content_hash(self.image.word_order))
        self._entry = fresh
        self._unsaved = record.start_run(self.address, old, fresh, [
            p.slot_label for p in self.image.programs if p.slot_label not in unchanged])
        return unchanged

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
        self._unsaved = True  # saved at the end of the run

    # ------------------------------------------------------------------ programs
    async def _program(self, program: FlashProgram, result: ProgramResult) -> None:
        start = time.monotonic()
        failures = 0
        self._forget(program.slot_label)
        while True:
            self._accepted, self._unanswered = 0, 0
            try:
                if failures:
                    await self._settle()
                mark = self._anomalies()
                await self._make_ready(program)
                result.downloads += 1
                await self._frames(program, result)
                await self._verify(program, result, mark)
                break
            except (LinkTimeout, LinkLost) as exc:
                failures += 1
                if failures > self.link.endpoint.retries:
                    left = await self._tidy(program)  # never leave a half download behind
                    raise FlashFailure("interrupted", f"{program.label}: {exc}; gave up after "
                                       f"{failures} downloads{left}") from None
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

    def _anomalies(self) -> tuple[int, int]:
        """The link's counts of answers nobody waited for: a change during a download means
        the device carried out a request the flasher did not send at that moment."""
        return self.link.anomalies, self.link.foreign_answers

    async def _span(self) -> list[int]:
        """Input registers 100-119: everything the device reports about its state."""
        return await self.link.read_input(STATE_REGISTER, STATE_SPAN)

    async def _settle(self) -> None:
        """Before a program is downloaded again: nothing sent earlier may still reach the
        device. A barrier on the same connection proves it; after a fresh connection the
        device's registers 100-119 must stay unchanged for a quiet period (a late create
        frame would show in register 100, a late close in 110-114)."""
        if await self.link.fence():
            return
        quiet = QUIET_TIMEOUTS * self.link.endpoint.timeout
        before = await self._span()
        for _round in range(QUIET_ROUNDS):
            await asyncio.sleep(quiet)
            after = await self._span()
            if after == before:
                return
            before = after
        raise LinkTimeout(f"{self.link.endpoint.describe()}: the device's state kept changing "
                          f"after a new connection (input registers 100-119 differ across "
                          f"{QUIET_ROUNDS} quiet periods of {quiet:g} s)")

    async def _make_ready(self, program: FlashProgram) -> None:
        """Bring a device left in a download state back to ready (step 1 of the module
        docstring). A download this flash did not open may be another client's, still
        going: the device must stay unchanged for a quiet period before it is closed."""
        (state,) = await self.link.read_input(STATE_REGISTER, 1)
        if state == 0:
            self._opened = None
            return
        if state not in (1, 2):
            raise FlashFailure("rejected", f"input register {STATE_REGISTER} reads {state}, "
                               "not a state of the M8194H (0 ready, 1/2 MP/ISR download)")
        if self._opened is None:
            await self._stray_download()
        kind = "mp" if state == 1 else "isr"
        await self._write(self._encoder().close_frame(kind), None)
        self._opened = None
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        if registers[0] != 0:
            raise FlashFailure("rejected", f"the device stays in {state_name(registers[0])} "
                               "state after a close frame")
        mp_no, isr_no, _command, _line, error = registers[STATUS_FIRST - STATE_REGISTER:]
        slot = mp_no if kind == "mp" else isr_no
        self._note(f"the device was in {state_name(state)} state (a download cut short): "
                   f"closed it{f' ({kind.upper()}{slot})' if slot else ''}")
        if slot and error == 0 and (kind, slot) != (program.kind, program.slot):
            await self._empty(kind, slot)

    async def _stray_download(self) -> None:
        """The device is in a download this flash did not open: cut short long ago, or
        another client's that is still going. Registers 100-119 that change within a quiet
        period mean the latter."""
        before = await self._span()
        await asyncio.sleep(QUIET_TIMEOUTS * self.link.endpoint.timeout)
        after = await self._span()
        if after != before:
            raise OtherClient(self._other_client(before[0], after))

    def _other_client(self, state: int, span: list[int] | None) -> str:
        """What another client is doing, as precisely as registers 100-119 tell."""
        kind = {1: "an MP", 2: "an ISR"}.get(state, "a")
        what = f"another client is downloading {kind} program"
        if span is not None and span[0] == 0:
            mp_no, isr_no = span[STATUS_FIRST - STATE_REGISTER:STATUS_FIRST - STATE_REGISTER
                                  + 2]
            slot = f"MP{mp_no}" if mp_no else f"ISR{isr_no}" if isr_no else None
            if slot is not None:
                what = f"another client is downloading {slot}"
                what += " (input registers 110/111 name it after its close)"
        elif span is not None:
            what += f" (input register {STATE_REGISTER}: {state_name(span[0])})"
        return (f"{what}: this flash stopped without touching its download; flash again "
                "when the other client is done")

    async def _await_other_client(self, state: int) -> str:
        """Our create was refused while the device is in a download we did not open: wait a
        while for the other client's close, whose status names its program."""
        span: list[int] | None = None
        for _round in range(QUIET_ROUNDS):
            await asyncio.sleep(QUIET_TIMEOUTS * self.link.endpoint.timeout)
            span = await self._span()
            if span[0] == 0:
                break
        return self._other_client(state, span)

    async def _empty(self, kind: str, slot: int) -> None:
        """Download an empty program into a slot a cut-short download left a truncated
        program in: an empty program returns at once when called, a truncated one may not.
        Verified like any program: ready, 110/111 name the slot, no download error."""
        encoder = self._encoder()
        self._forget(f"{kind.upper()}{slot}")
        self._opened = (kind, slot)
        await self._write(encoder.create_frame(kind, slot), None)
        await self._write(encoder.close_frame(kind), None)
        self._opened = None
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        expected = (slot, 0) if kind == "mp" else (0, slot)
        status = registers[STATUS_FIRST - STATE_REGISTER:]
        if registers[0] != 0 or tuple(status[:2]) != expected or status[4] != 0:
            raise FlashFailure("unverified", f"emptying {kind.upper()}{slot} was not "
                               f"confirmed (input registers 100, 110-114 read {registers[0]}, "
                               f"{status})")
        self._note(f"{kind.upper()}{slot} held a truncated program: emptied it")

    async def _write(self, frame: list[int], result: ProgramResult | None,
                     refused: DeviceException | None = None) -> None:
        """One frame; a busy device (exception 0x06, or cause 0xC1 DPRAM full) gets the same
        frame again after growing pauses. Any other refusal raises Refused, with the cause in
        words. `refused`: the device's answer to the frame sent already (`_frames`)."""
        waited = 0.0
        attempt = 0
        while True:
            if refused is None:
                try:
                    await self.link.write_frame(frame)
                    return
                except DeviceException as answer:
                    refused = answer
            exc, refused = refused, None
            cause = None
            if exc.code == ILLEGAL_FUNCTION:
                (cause,) = await self.link.read_input(CAUSE_REGISTER, 1)
            if exc.code != DEVICE_BUSY and cause != DPRAM_FULL:
                reason = exc.name if cause is None else (
                    f"{exc.name}, cause not recorded (input register {CAUSE_REGISTER} "
                    "reads 0: another client's request may have reset it)" if cause == 0
                    else f"{exc.name}, cause {cause:#04x} ("
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

    async def _frames(self, program: FlashProgram, result: ProgramResult) -> None:
        """Every frame of `program`, create to close. A line the device accepts at once is
        sent and counted here, without `_send`'s coroutine: the flasher's own time a frame
        is part of a flash's floor. Anything else (the create and the close, a refusal, a
        busy device, no answer) is `_send`'s, as it is for every frame."""
        frames, write = program.frames, self.link.write_frame
        last, rtu = len(frames) - 1, self.link.endpoint.host is None
        for index in range(len(frames)):
            if rtu and index and len(frames[index]) == len(frames[index - 1]):
                await self._separate()
            if not 0 < index < last:
                await self._send(program, result, index)
                continue
            try:
                await write(frames[index])
            except (LinkTimeout, LinkLost):
                self._unanswered = 1
                raise
            except DeviceException as exc:
                await self._send(program, result, index, exc)
                continue
            self.report.frames_written += 1
            self._accepted += 1

    async def _separate(self) -> None:
        """Over RTU, a read between two frames of one length. Their FC16 answers are the
        same bytes (the address and the register count), so a line frame the link repeats
        while it loses the next one leaves one answer standing in for the other: the device
        holds a line twice and misses one, and nothing else tells (registers 110-114 hold no
        line count). A read's answer differs from a write's, so that pair of faults now
        meets an answer of the wrong kind and the program is downloaded again."""
        await self.link.read_input(STATE_REGISTER, 1)

    async def _send(self, program: FlashProgram, result: ProgramResult, index: int,
                    refused: DeviceException | None = None) -> None:
        frame = program.frames[index]
        if index == 0:
            self._opened = (program.kind, program.slot)  # from here on it may be open
        try:
            try:
                await self._write(frame, result, refused)
            except (LinkTimeout, LinkLost):
                self._unanswered = 1
                raise
        except FlashFailure as failure:  # the device stayed busy: close what was opened
            if index > 0:
                failure.args = (f"{failure}{await self._tidy(program)}",)
            raise
        except Refused as refusal:
            await self._refused(program, index, refusal)
        self.report.frames_written += 1
        if 0 < index < len(program.frames) - 1:
            self._accepted += 1
        elif index == len(program.frames) - 1:
            self._opened = None

    async def _refused(self, program: FlashProgram, index: int, refusal: Refused) -> None:
        """The device refused frame `index` of `program`: say why, at its source line, and
        tidy up, unless another client's download explains the refusal."""
        frame = program.frames[index]
        if refusal.code == ILLEGAL_FUNCTION:
            (state,) = await self.link.read_input(STATE_REGISTER, 1)
            if index == 0 and state in (1, 2):
                self._opened = None
                raise OtherClient(f"{program.label}: the device refused the create frame: "
                                  f"{await self._await_other_client(state)}") from None
            if index > 0 and state == 0:
                self._opened = None
                raise OtherClient(f"{program.label}: the device refused frame "
                                   f"{index} because its download was closed by someone else "
                                   f"(input register {STATE_REGISTER} reads 0): another "
                                   f"client is downloading; {program.slot_label} may hold the "
                                   f"first {self._accepted} of its {len(program.frames) - 2} "
                                   "lines. Flash again when the other client is done: the "
                                   "flash writes it again") from None
            if index == 0 and refusal.cause == MACRO_RUNNING:
                running = await self._running()
                raise FlashFailure("rejected", f"{program.label}: nothing was written: "
                                   f"{running or 'a macro program'} is running (cause 0xc3); "
                                   "stop it, or let the flash stop it (mpc flash --stop-running)",
                                   program.where(index)) from None
        left = await self._tidy(program) if index > 0 else ""
        raise FlashFailure("rejected", f"{program.label}: the device refused frame "
                           f"{index} ({self._describe(frame)}): {refusal}{left}",
                           program.where(index)) from None

    async def _running(self) -> str | None:
        """The running MP by holding register 8, None if it reads 0 (none, or an ISR)."""
        try:
            (slot,) = await self.link.read_holding(CALL_REGISTER, 1)
        except (LinkError, DeviceException):
            return None
        return f"MP{slot}" if slot else None

    async def _check_running(self) -> None:
        """Before anything is written: a running program makes the device refuse downloads
        (cause 0xC3) and may be the one about to be replaced. Stop it only with consent."""
        running = await self._running()
        if running is None:
            return
        if not self.options.stop_running:
            raise FlashFailure("rejected", f"{running} is running (holding register "
                               f"{CALL_REGISTER} reads {running[2:]}): nothing was written; "
                               "stop it first, or let the flash stop it "
                               "(mpc flash --stop-running)")
        await self._stop_programs(running)

    async def _stop_programs(self, running: str | None) -> None:
        """RTC MP_TERMINATE (every MP and ISR; motion goes on), then wait until register 8
        reads 0."""
        code = self.catalogue.rtc_by_short["MP_TERMINATE"].code
        assert code is not None
        await self._write([code], None)
        deadline = time.monotonic() + self.options.busy_timeout
        while await self._running() is not None:
            if time.monotonic() > deadline:
                raise FlashFailure("rejected", f"{running} still runs "
                                   f"{self.options.busy_timeout:g} s after MP_TERMINATE")
            await asyncio.sleep(INIT_POLL_S)
        self._note(f"stopped {running or 'the running program'} (MP_TERMINATE), as asked")

    async def _tidy(self, program: FlashProgram) -> str:
        """After giving up on a program: end the download and empty the slot, so the device
        is ready and holds no truncated program, retried with growing pauses. Returns ""
        when done, else what the device may hold and how to repair it (for the message):
        the failure itself is what the user must see first."""
        problem = "no answer"
        for attempt in range(1, TIDY_ATTEMPTS + 1):
            try:
                await self._settle()
                (state,) = await self.link.read_input(STATE_REGISTER, 1)
                if state in (1, 2):
                    await self._write(self._encoder().close_frame(
                        "mp" if state == 1 else "isr"), None)
                    self._opened = None
                await self._empty(program.kind, program.slot)
                return ""
            except Refused as refusal:
                problem = str(refusal)
                if refusal.cause == MACRO_RUNNING:
                    running = await self._running()
                    if not self.options.stop_running:
                        problem = (f"the device will not empty it while "
                                   f"{running or 'a macro program'} runs (cause 0xc3)")
                        break
                    try:
                        await self._stop_programs(running)
                    except (LinkError, DeviceException, Refused, FlashFailure) as exc:
                        problem = str(exc)
            except (LinkError, DeviceException, FlashFailure) as exc:
                problem = str(exc)
            await asyncio.sleep(backoff(attempt, TIDY_PAUSE_MAX_S, TIDY_PAUSE_FIRST_S))
        lines = len(program.frames) - 2
        held = f"the first {self._accepted}" + (
            f" or {self._accepted + 1}" if self._unanswered and self._accepted < lines else "")
        left = (f"; the tidy-up failed ({problem}): {program.slot_label} may hold {held} of "
                f"its {lines} lines, and the device may still be in download state. Repair: "
                f"run the flash again (it closes an open download and writes "
                f"{program.slot_label} again)")
        self._note(left[2:])
        return left

    async def _verify(self, program: FlashProgram, result: ProgramResult,
                      mark: tuple[int, int]) -> None:
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        state = registers[0]
        status = registers[STATUS_FIRST - STATE_REGISTER:]
        result.download_status = status
        mp_no, isr_no, command, line, error = status
        expected = (program.slot, 0) if program.kind == "mp" else (0, program.slot)
        if self._anomalies() != mark:
            # no label: the retry note and the final failure put it before the message
            raise LinkTimeout("an answer arrived that no request was waiting for (a delayed "
                              "or duplicated request): the device may hold a line twice")
        if state != 0:
            raise FlashFailure("unverified", f"{program.label}: the device is in "
                               f"{state_name(state)} state after the close frame",
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
        self._last_status = status

    async def _final_check(self) -> None:
        """After the last program: fence, and the device must still be ready with the
        download status the last verification read, so a late create or close frame that
        reached it after a verification shows (a late line frame meets a ready device,
        which refuses it)."""
        if self._last_status is None:
            return
        status = self._last_status
        await self._settle()
        registers = await self.link.read_input(STATE_REGISTER, STATUS_FIRST + STATUS_COUNT
                                               - STATE_REGISTER)
        now = registers[STATUS_FIRST - STATE_REGISTER:]
        if registers[0] != 0 or now != status:
            raise FlashFailure("unverified", f"after the last verification the device changed "
                               f"(input register {STATE_REGISTER}: {state_name(registers[0])}; "
                               f"110-114: {now}, verified as {status}): a delayed request "
                               "reached it; flash again")

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
