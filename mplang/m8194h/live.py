"""`mpc monitor` for the M8194H: the live state of one controller, polled over Modbus TCP or
RTU with the reads `mpc status` makes (`mplang.m8194h.status`), kept small enough to repeat
many times a second, and the few writes the dashboard offers with `--allow-write`.

One poll is four reads: input registers 8-61 (FRnet DI groups, each axis's DI status, error
code, running program, emergency state, LP/EP/CV, stop status), input 100-119 (state,
download and execution status), holding 8-14 (the called MP, the word order) and the
declared variables (holding 300 + 2n, one read per 60 of them). The identity (input 81-85)
is read once per connection. The device has no register for the line a program is at, so
the running program's source place is where it is declared; an execution error (115-119)
is placed at its own line through the build's spans, as `mpc run` places its findings.

`Watcher` is the family face's `LiveDevice` (`Family.watch`).
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Mapping
from typing import Any

from mplang.family.face import CommandError, DeviceUnreachable, WatchJob
from mplang.ir.catalogue import Catalogue
from mplang.ir.catalogue import load as load_catalogue
from mplang.m8194h.encode import join32, split32
from mplang.m8194h.flash.lease import Lease, LeaseSettings
from mplang.m8194h.flash.registers import (
    CALL_REGISTER,
    IDENTITY_COUNT,
    IDENTITY_FIRST,
    STATE_REGISTER,
    STATE_SPAN,
    WORD_ORDER_REGISTER,
    state_name,
)
from mplang.m8194h.image import BuildResult, ProgramImage
from mplang.m8194h.modbus import DeviceException, DeviceLink, Endpoint, LinkError
from mplang.m8194h.status import AXES, VAR_BASE, lamp_bits
from mplang.m8194h.status import lamps as axis_lamps

LIVE_FIRST, LIVE_COUNT = 8, 54  # input 8-15 FRnet DI groups 8-15, then 16-61 as in status
HOLDING_FIRST = CALL_REGISTER  # holding 8 (called MP) .. 14 (word order)
HOLDING_COUNT = WORD_ORDER_REGISTER - CALL_REGISTER + 1
VARS_PER_READ = 60  # 120 registers: within FC3's 125
ACTIONS = ("call", "set_var", "stop", "emergency_stop", "clear_emergency")
LEASE_FREE = frozenset({"stop", "emergency_stop"})
"""Writes never held back by a flash's download lease: stopping must always work."""
INT32 = (-(1 << 31), (1 << 31) - 1)


class Watcher:
    """One controller watched live; the connection opens on the first read and again after
    a failure, so a device that restarts is seen again by itself."""

    def __init__(self, endpoint: Endpoint, build: BuildResult | None = None,
                 catalogue: Catalogue | None = None) -> None:
        self.endpoint = endpoint
        self.build = build
        self.catalogue = catalogue or load_catalogue()
        self.link: DeviceLink | None = None
        self.identity: dict[str, int] | None = None
        self.word_order = 0
        raw = self.catalogue.profile.raw
        self.lamp_bits = lamp_bits(self.catalogue)  # the profile's [lamps], as mpc status
        self.errors: dict[str, str] = raw.get("execution_errors", {})
        self.variables = sorted([*build.variables, *build.aliases] if build else [],
                                key=lambda v: v.index)
        self.programs = [{"slot": f"{i.program.kind.upper()}{i.placement.slot}",
                          "name": i.program.name or "",
                          "source": f"{i.program.span.file}:{i.program.span.line}"}
                         for i in (build.programs if build else [])]
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

    # ------------------------------------------------------------------ connection
    async def _link(self) -> DeviceLink:
        if self.link is None:
            link = DeviceLink(self.endpoint)
            try:
                await link.open()
                (self.word_order,) = await link.read_holding(WORD_ORDER_REGISTER, 1)
                ident = await link.read_input(IDENTITY_FIRST, IDENTITY_COUNT)
            except BaseException:
                link.close()
                raise
            order = self.word_order
            self.identity = {"module_id": ident[0],
                             "rsm_firmware": join32(ident[1:3], order, False),
                             "i8094h_firmware": join32(ident[3:5], order, False)}
            self.link = link
        return self.link

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
            self.link = None

    async def _guarded_link(self) -> DeviceLink:
        try:
            return await self._link()
        except (LinkError, DeviceException, OSError) as exc:
            self.close()
            raise DeviceUnreachable(f"{self.endpoint.describe()}: {exc}") from None

    def _lost(self, exc: Exception) -> DeviceUnreachable:
        self.close()
        return DeviceUnreachable(f"{self.endpoint.describe()}: {exc}")

    # ----------------------------------------------------------------------- reads
    async def read(self) -> dict[str, Any]:
        """The state now (docs/monitor.md lists the fields); DeviceUnreachable when the
        device cannot be read."""
        link = await self._guarded_link()
        try:
            regs = await link.read_input(LIVE_FIRST, LIVE_COUNT)
            span = await link.read_input(STATE_REGISTER, STATE_SPAN)
            holding = await link.read_holding(HOLDING_FIRST, HOLDING_COUNT)
            values = await self._read_vars(link)
        except (LinkError, DeviceException) as exc:
            raise self._lost(exc) from None
        order = holding[WORD_ORDER_REGISTER - HOLDING_FIRST]
        self.word_order = order
        running, top = holding[0], regs[24 - LIVE_FIRST]
        execution = span[15:20]
        return {
            "device": self.endpoint.describe(),
            "identity": self.identity,
            "word_order": order,
            "state": {"value": span[0], "name": state_name(span[0]), "i8094h_state": span[1],
                      "cause": span[2]},
            "download_status": _five(span[10:15]),
            "running": self._running(running, top),
            "execution_error": self._execution_error(execution),
            "emergency": bool(regs[25 - LIVE_FIRST]),
            "frnet_di": regs[0:8],
            "axes": [self._axis(regs, n, order) for n in range(len(AXES))],
            "variables": [{"name": v.name, "var": v.index, "value": values[v.index]}
                          for v in self.variables],
            "programs": self.programs,
        }

    async def _read_vars(self, link: DeviceLink) -> dict[int, int]:
        """The declared variables' values by index, read in runs of up to 60."""
        wanted = sorted({v.index for v in self.variables})
        values: dict[int, int] = {}
        while wanted:
            first = wanted[0]
            run = [n for n in wanted if n < first + VARS_PER_READ]
            last = run[-1]
            words = await link.read_holding(VAR_BASE + 2 * first, 2 * (last - first + 1))
            for n in run:
                at = 2 * (n - first)
                values[n] = join32(words[at:at + 2], self.word_order)
            wanted = wanted[len(run):]
        return values

    def _axis(self, regs: list[int], n: int, order: int) -> dict[str, Any]:
        def pair(first: int) -> int:
            at = first - LIVE_FIRST + 2 * n
            return join32(regs[at:at + 2], order)
        status = regs[16 - LIVE_FIRST + n]
        lamps = axis_lamps(status, self.lamp_bits)
        stopped = regs[58 - LIVE_FIRST + n] == 1
        return {"axis": AXES[n], "lp": pair(26), "ep": pair(34), "cv": pair(42),
                "state": "stopped" if stopped else "moving", "di_status": status,
                "error_code": regs[20 - LIVE_FIRST + n], "lamps": lamps}

    def _running(self, mp: int, top: int) -> dict[str, Any]:
        """Holding 8 (the called MP) and input 24 (what runs now: an ISR above it shows
        there), with the program's name and declaration when the build has it."""
        kind, slot = ("mp", mp) if mp else ("isr", top) if top else ("", 0)
        image = self._image(kind, slot) if kind else None
        label = f"{kind.upper()}{slot}" if kind else None
        if image is not None and image.program.name and label is not None:
            label += f" {image.program.name}"
        where = None
        if image is not None:
            where = f"{image.program.span.file}:{image.program.span.line}"
        return {"mp": mp, "top": top, "program": label, "source": where}

    def _execution_error(self, values: list[int]) -> dict[str, Any]:
        out: dict[str, Any] = {**_five(values), "text": None, "source": None}
        if not out["error"]:
            return out
        out["text"] = self.errors.get(f"0x{out['error']:02X}", "unknown execution error")
        kind, slot = ("isr", out["isr"]) if out["isr"] else ("mp", out["mp"])
        image = self._image(kind, slot)
        if image is not None:
            out["source"] = _source_line(image, out["line"])
        return out

    def _image(self, kind: str, slot: int) -> ProgramImage | None:
        for image in self.build.programs if self.build is not None else ():
            if (image.program.kind, image.placement.slot) == (kind, slot):
                return image
        return None

    # ---------------------------------------------------------------------- writes
    async def act(self, action: str, args: Mapping[str, Any]) -> str:
        """One write of the dashboard; what it did in words. CommandError("input") for a
        request that names nothing the device or build has."""
        if action not in ACTIONS:
            raise CommandError("input", f"unknown action {action!r}: one of "
                               f"{', '.join(ACTIONS)}")
        link = await self._guarded_link()
        try:
            if action not in LEASE_FREE:
                await self._refuse_if_leased(link)
            if action == "call":
                slot, label = self._program(args.get("program"))
                await link.write_once(CALL_REGISTER, [slot])
                return f"called {label} (holding register {CALL_REGISTER} = {slot})"
            if action == "set_var":
                index, label = self._variable(args.get("name"))
                value = _int32(args.get("value"))
                await link.write_holding(VAR_BASE + 2 * index, split32(value, self.word_order))
                return f"{label} = {value}"
            if action == "stop":
                await self._rtc(link, "MP_TERMINATE")
                await self._rtc(link, "STOP_SLOWLY", self._all_axes())
                return "stopped every program (MP_TERMINATE) and every axis (STOP_SLOWLY)"
            if action == "emergency_stop":
                await self._rtc(link, "EMERGENCY_STOP", 0)
                return "emergency stop (EMERGENCY_STOP, at once)"
            await self._rtc(link, "CLEAR_EMERGENCY_STOP")
            return "emergency stop cleared (CLEAR_EMERGENCY_STOP)"
        except DeviceException as exc:
            raise CommandError("input", f"the device refused it: {exc}") from None
        except LinkError as exc:
            raise self._lost(exc) from None

    async def _refuse_if_leased(self, link: DeviceLink) -> None:
        """A write while another client holds the device's download lease (a flash is
        writing it) is refused, naming that client: a call or a variable could meet a
        half-written program."""
        lease = Lease(link, LeaseSettings.of(self.catalogue.profile), self.word_order)
        held = await lease.read()
        now = time.time()
        if held is not None and not held.expired(now):
            raise CommandError("leased", f"refused: the device is leased by "
                               f"{held.describe(now)}; write again when that flash is done")

    async def _rtc(self, link: DeviceLink, short: str, *params: int) -> None:
        """A real-time command frame at the sub-function window (FC16, register 8000)."""
        code = self.catalogue.rtc_by_short[short].code
        assert code is not None
        await link.write_frame([code, *params])

    def _all_axes(self) -> int:
        code = self.catalogue.profile.axis_code("".join(AXES))
        assert code is not None
        return code

    def _program(self, given: object) -> tuple[int, str]:
        """`MP3`, `3` or a declared MP name -> its slot number and a label."""
        text = str(given if given is not None else "").strip()
        for image in self.build.programs if self.build is not None else ():
            program = image.program
            if program.kind == "mp" and program.name and program.name == text:
                return image.placement.slot, f"MP{image.placement.slot} {program.name}"
        found = re.fullmatch(r"(?i)(?:mp)?\s*(\d{1,3})", text)
        slots = self.catalogue.profile.slot_numbers("mp")
        if found is None or int(found[1]) not in slots:
            raise CommandError("input", f"no MP {text!r}: give a declared MP name or "
                               f"MP{slots[0]}..MP{slots[-1]}")
        return int(found[1]), f"MP{int(found[1])}"

    def _variable(self, given: object) -> tuple[int, str]:
        """A declared name or `VARn` -> its index and a label."""
        text = str(given if given is not None else "").strip()
        for variable in self.variables:
            if variable.name == text:
                return variable.index, f"{variable.name} (VAR{variable.index})"
        found = re.fullmatch(r"(?i)var(\d{1,3})", text)
        count = int(self.catalogue.profile.raw["variables"]["count"])
        if found is None or int(found[1]) >= count:
            raise CommandError("input", f"no variable {text!r}: give a declared name or "
                               f"VAR0..VAR{count - 1}")
        return int(found[1]), f"VAR{int(found[1])}"


def _five(values: list[int]) -> dict[str, int]:
    mp_no, isr_no, command, line, error = values
    return {"mp": mp_no, "isr": isr_no, "command": command, "line": line, "error": error}


def _int32(value: object) -> int:
    try:
        number = int(str(value).strip(), 0)
    except ValueError:
        raise CommandError("input", f"not a whole number: {value!r}") from None
    if not INT32[0] <= number <= INT32[1]:
        raise CommandError("input", f"{number} is outside a VAR's 32-bit range")
    return number


def _source_line(image: ProgramImage, slot_line: int) -> str:
    """The source place of a 0-based slot line (a macro line spans `line_cost` of them; past
    the last, the closing line)."""
    for frames in image.lines:
        first = frames.first_slot_line
        if first <= slot_line < first + max(1, frames.line.command.line_cost):
            span = frames.line.span
            return f"{span.file}:{span.line}"
    return f"{image.close_span.file}:{image.close_span.line}"


def watch(job: WatchJob) -> Watcher:
    """The family face's `watch`: a `Watcher` of the job's device (its own timeout and
    retries; nothing is read until the first `read`)."""
    device = job.device
    endpoint = Endpoint(host=device.host, port=device.port, serial=device.serial,
                        baudrate=device.baud, parity=device.parity, stopbits=device.stopbits,
                        unit=device.unit, timeout=job.timeout, retries=job.retries)
    build = job.build if isinstance(job.build, BuildResult) else None
    return Watcher(endpoint, build)
