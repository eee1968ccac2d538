"""The CSIM's host side (`mpc call`, `mpc var`, `mpc export`, `mplang.host`): a build's
names as a host sees them (`view_of`), and one CSIM spoken to in those names over its RS232
command set (`CsimHost`), after checking that it holds the host's program.

A CSIM keeps no build manifest. What identifies its program is the program itself: ULP
(CS 119) lists it back exactly as it was downloaded, and the build id of a CSIM build is a
hash of those lines, so the device's listing names a build id too. A program starts with
`G $LABEL` (CS 78: the address may be a label); `?ST` (CS 152) says whether one runs, `?ERR`
(CS 167) whether it stopped on an error; `?Rk` (CS 155) reads the R variable a declared
`.mp` variable became and `Rk=value` (CS 137) writes it; `?PE` / `?TpPE` (CS 156, 171) read
the positions. The answers' formats are the protocol reading of stdlib/csim/device.toml
([protocol], [host]).
"""

from __future__ import annotations

import asyncio
import hashlib
import re
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypeVar

import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.csim import profile as profile_module
from mplang.csim.build import CsimProgram, FamilyBuild, check_native
from mplang.csim.compile import compile_mp
from mplang.csim.download import DownloadError, SerialLine, open_port
from mplang.csim.machine_state import format_number
from mplang.csim.status import first_difference
from mplang.family.hostview import (
    BuildMismatch,
    ExecutionError,
    HostConst,
    HostError,
    HostLinkError,
    HostProgram,
    HostValue,
    HostVariable,
    HostView,
    ProgramRunning,
    WaitTimeout,
)
from mplang.ir.unit import Options
from mplang.lang.limits import read_json_file

T = TypeVar("T")

FAMILY = "CSIM"
PROTOCOL = "rs232-ascii"
AXES = ("X", "Y", "Z", "U")  # modules T0..T3, as `.mp` axes compile to them (docs/csim.md)
ERROR_CODE = "R401"  # a run-time finding the device reports without saying which
_MP_SLOT = re.compile(r"MP(\d+)")


def build_id(lines: Sequence[str]) -> str:
    """The id of a CSIM program: a hash of its lines as ULP lists them back."""
    return hashlib.sha256("\n".join(lines).encode()).hexdigest()[:16]


def _host() -> dict[str, Any]:
    return profile_module.load().section("host")


def view_of(program: CsimProgram) -> HostView:
    """The host's view of a CSIM build: its entries (a compiled build's MPs, a script's
    labels) called with `G $LABEL`, its declared variables at their R variables, its
    CONSTs, and its lines (what ULP must list)."""
    labels = program.script.labels
    programs: list[HostProgram] = []
    if program.entries:
        by_label: dict[str, list[str]] = {}
        for key, label in program.entries.items():
            by_label.setdefault(label, []).append(key)
        for label, keys in by_label.items():
            slot = next((int(m.group(1)) for k in keys if (m := _MP_SLOT.fullmatch(k))), -1)
            name = next((k for k in keys if not _MP_SLOT.fullmatch(k)), "")
            programs.append(_entry(program, label, "mp", name, slot))
    else:
        programs.append(HostProgram(program.name, "program", 0, f"{program.source}:1",
                                    None, "G", device="G"))
        for label in labels:
            programs.append(_entry(program, f"${label}", "label", label, labels[label]))
    kind_of = {name: "var" for name in program.names}
    variables = [HostVariable(
        name, kind_of[name], rvar, int(rvar[1:]), int(rvar[1:]), f"?{rvar} / {rvar}=v", 1,
        str(_host()["real_variables"]), "", "read-write", program.declared_at.get(name, ""))
        for name, rvar in program.names.items()]
    consts = [HostConst(name, value, at) for name, value, at in program.consts]
    return HostView(FAMILY, build_id(program.lines), 0, programs, variables, consts,
                    PROTOCOL, list(program.lines))


def _entry(program: CsimProgram, label: str, kind: str, name: str, slot: int) -> HostProgram:
    """One callable label: where it was written, and the declared variables it writes."""
    address = program.script.labels[label[1:].upper()]
    origin = program.origins[address]
    return HostProgram(name, kind, slot, f"{origin.file}:{origin.line}", None, f"G {label}",
                       _writes(program, address), device=label)


def _writes(program: CsimProgram, start: int) -> tuple[str, ...]:
    """The declared variables the lines from `start` assign until the RET that returns to
    the host, following CALLs and jumps (each line visited once)."""
    statements = program.script.statements
    labels = program.script.labels
    declared = {rvar.upper(): name for name, rvar in program.names.items()}
    found: set[str] = set()
    todo, seen = [start], set()
    while todo:
        address = todo.pop()
        if address in seen or address >= len(statements):
            continue
        seen.add(address)
        st = statements[address]
        if st.kind == "assign" and st.target is not None and st.name in declared:
            found.add(declared[st.name])
        targets = [labels.get(op.text[1:].upper()) for op in st.operands if op.kind == "label"]
        todo += [t for t in targets if t is not None]
        if not (st.kind == "command" and st.name in ("RET", "JP")):
            todo.append(address + 1)
    return tuple(sorted(found))


def compile_view(paths: list[Path], options: Options) -> tuple[FamilyBuild, HostView]:
    """Build `.mp` sources (with `--target csim`) or `.csim` scripts, and the view of the
    build's one program (an empty view where the build has errors)."""
    if paths and all(p.suffix.lower() == ".csim" for p in paths):
        build = check_native(paths)
    else:
        build = compile_mp(paths, options, "csim")
    if not build.ok or not build.programs:
        return build, HostView(FAMILY, "", 0, protocol=PROTOCOL)
    if len(build.programs) > 1:
        raise HostError(f"{len(build.programs)} .csim scripts are {len(build.programs)} "
                        "programs, and a CSIM holds one: give the one it holds")
    return build, view_of(build.programs[0])


def load_view(path: Path) -> HostView:
    """A view from what `mpc export --format json` wrote for a CSIM build."""
    view = HostView.from_json(read_json_file(path, errors="strict"))
    if view.protocol != PROTOCOL:
        raise ValueError(f"a host view of a {view.family} build, not of a CSIM build")
    return view


def located(view: HostView, error: Sequence[int]) -> ExecutionError:
    """The device's error number as an ExecutionError: without a source line, since the
    CSIM does not say where its program stopped (device.toml [host] error_choice)."""
    number = int(error[0]) if error else 0
    return ExecutionError(
        ERROR_CODE, f"the CSIM reports error {number} (?ERR); it does not say at which "
        "program line it stopped, so no source line can be given", None, None, number,
        "the CSIM program")


class CsimHost:
    """One CSIM on a serial line, spoken to in a build's names. pyserial is blocking: each
    exchange runs in a worker thread, one at a time (a CSIM has one line and one host)."""

    def __init__(self, port: str, baud: int, parity: str, stopbits: int,
                 timeout: float) -> None:
        self.port = port
        self.where = f"{port} ({baud} 8{parity}{stopbits})"
        self.settings = (baud, parity, stopbits, timeout)
        self.line: SerialLine | None = None
        self.calls = 0  # programs this host started (G)
        self.lock = asyncio.Lock()
        host = _host()
        self.running_states = frozenset(str(s) for s in host["running_states"])
        self.no_error = str(host["no_error"])
        self.poll_s = float(host["poll_s"])

    async def __aenter__(self) -> CsimHost:
        baud, parity, stopbits, timeout = self.settings
        try:
            link = await asyncio.to_thread(open_port, self.port, baud, parity, stopbits,
                                           timeout)
        except DownloadError as exc:
            raise HostLinkError(exc.message, reached=False) from None
        link.reset_input_buffer()
        self.line = SerialLine(link, self.port)
        await self.query("?ST", first=True)
        return self

    async def __aexit__(self, *_exc: object) -> None:
        if self.line is not None:
            self.line.port.close()
            self.line = None

    def describe(self) -> str:
        return f"CSIM on {self.where}"

    async def _send(self, text: str, answers: bool = False, first: bool = False
                    ) -> list[str]:
        """One line and its data lines; the CSIM's refusals and silences as HostLinkError
        (silence on the first question: no device)."""
        line = self.line
        if line is None:
            raise HostLinkError("the CSIM's line is not open", reached=False)
        async with self.lock:
            try:
                return await asyncio.to_thread(line.send, text, answers)
            except DownloadError as exc:
                if exc.kind == "no-answer":
                    raise HostLinkError(exc.message, reached=not first) from None
                raise HostLinkError(exc.message, refused=exc.kind == "device-error"
                                    ) from None
            except (serial.SerialException, OSError) as exc:
                raise HostLinkError(f"{self.port}: {exc}") from None

    async def query(self, text: str, first: bool = False) -> str:
        data = await self._send(text, answers=True, first=first)
        if len(data) != 1:
            raise HostLinkError(f"the CSIM answered {text!r} with {len(data)} lines, not one")
        return data[0].strip()

    async def word_order(self) -> int:
        return 0  # no 32-bit register pairs: values travel as text

    async def check(self, view: HostView) -> None:
        """ULP against the build: the same lines, or BuildMismatch (nothing written)."""
        if await self.running():
            raise ProgramRunning("a program is running, and a running CSIM does not list its "
                                 "program (ULP), so it cannot be compared with the build "
                                 "before anything is written: wait for it to end (or stop it "
                                 "with EXIT), or skip the check (--no-check, check=False)")
        listing = await self._send("ULP")
        if not listing:
            raise BuildMismatch(None, view.build_id, "ULP lists nothing", held="no program")
        held = build_id(listing)
        if held == view.build_id:
            return
        reason = "its program listing (ULP) is another program"
        if view.listing:
            reason = "its program listing (ULP) differs: " + first_difference(view.listing, listing)
        raise BuildMismatch(held, view.build_id, reason)

    async def read(self, var: HostVariable) -> HostValue:
        answer = await self.query(f"?{var.device_name}")
        try:
            value = float(answer)
        except ValueError:
            raise HostLinkError(f"the CSIM answered ?{var.device_name} with {answer!r}, "
                                "not a number") from None
        return int(value) if value.is_integer() else value

    async def write(self, var: HostVariable, value: Any) -> None:
        await self._send(f"{var.device_name}={format_number(float(value))}")

    async def running(self) -> int:
        """1 while ?ST answers a running state (the CSIM runs one program), else 0."""
        return 1 if await self.query("?ST") in self.running_states else 0

    async def last_error(self) -> tuple[int, ...]:
        """(0,) without an error, else (its number, the calls this host made): G clears the
        error (device.toml [host] error_choice), so an error after this host's call is that
        call's, even with the number an earlier one had."""
        answer = await self.query("?ERR")
        if answer == self.no_error:
            return (0,)
        try:
            number = int(float(answer)) or 1
        except ValueError:
            number = 1  # an error the device names in words: an error all the same
        return (number, self.calls)

    async def start(self, program: HostProgram) -> None:
        await self._send(program.function)
        self.calls += 1

    async def wait(self, timeout: float | None) -> float:
        began = time.monotonic()
        while await self.running():
            waited = time.monotonic() - began
            if timeout is not None and waited >= timeout:
                raise WaitTimeout(f"the program still runs after {timeout:g} s (the CSIM on "
                                  f"{self.where} answers ?ST with a running state)")
            await asyncio.sleep(self.poll_s)
        return time.monotonic() - began

    async def axes(self) -> dict[str, dict[str, Any]]:
        """Modules T0..T3 as X..U: ?PE, ?T1PE, ...; one state for all from ?ST (the list has
        no query of one module's motion)."""
        state = await self.query("?ST")
        shown = "moving" if state == "MOVE" else "running" if state in \
            self.running_states else "stopped"
        found: dict[str, dict[str, Any]] = {}
        for module, name in enumerate(AXES):
            answer = await self.query(f"?T{module}PE" if module else "?PE")
            try:
                value = float(answer)
            except ValueError:
                raise HostLinkError(f"the CSIM answered the position of T{module} with "
                                    f"{answer!r}, not a number") from None
            found[name] = {"position": int(value) if value.is_integer() else value,
                           "state": shown}
        return found

