"""The M8194H's host side (`mpc call`, `mpc var`, `mpc export`, `mplang.host`): a build's
names as a host sees them (`view_of`), and one device spoken to in those names over Modbus
(`ModbusHost`), after checking that it holds the host's build.

A host starts MPn by writing n to holding register 8 and reads it back to see whether the
program still runs (0: none); VARn is the 32-bit value at holding registers 300 + 2n (RS
2403), bVARn the byte at 128 + n (RS 2350), MDn at 3000 + 2n (RS 2528), 32-bit values in the
device's word order (holding register 14). The build the device holds is what its build
manifest says (`flash.manifest`), trusted only while the download status it recorded (input
registers 110-114) is the device's: any download since changes them. The last execution
error is input registers 115-119 (RS 11385-11393): MP, ISR, command, 0-based line, error.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from mplang.family.hostview import (
    BuildMismatch,
    ExecutionError,
    HostConst,
    HostLine,
    HostLinkError,
    HostProgram,
    HostVariable,
    HostView,
    WaitTimeout,
)
from mplang.ir import catalogue as catalogue_module
from mplang.ir.macro import ProgramRef, VarRef
from mplang.ir.unit import Options
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.limits import read_json_file
from mplang.lang.runtime_rules import RUNTIME_RULES
from mplang.lang.sources import load_sources
from mplang.m8194h.compiler import Lowering, compile_sources
from mplang.m8194h.encode import join32, split32
from mplang.m8194h.flash import manifest as mf
from mplang.m8194h.flash.registers import (
    CALL_REGISTER,
    STATE_REGISTER,
    STATE_SPAN,
    WORD_ORDER_REGISTER,
)
from mplang.m8194h.image import BuildResult
from mplang.m8194h.modbus import DeviceException, DeviceLink, Endpoint, LinkError, LinkUnavailable

T = TypeVar("T")

FAMILY = "M8194H"
AXES = ("X", "Y", "Z", "U")
LP_FIRST, STOPPED_FIRST = 26, 58  # input: LP pairs of X..U, stop status (1 stopped)
WRITE_FUNCTIONS = "3/16"  # read with FC3, write with FC16
ORDER_NAMES = ("msw-first", "lsw-first")


def _profile() -> Any:
    return catalogue_module.load().profile


def view_of(build: BuildResult, consts: Sequence[HostConst] = ()) -> HostView:
    """The host's view of an M8194H build: every program (an MP callable at holding register
    8), every declared variable (VAR name, ALIAS) at its holding register, the CONSTs."""
    profile = _profile()
    base = int(profile.var("holding_base"))
    order = ORDER_NAMES[build.word_order]
    variables: list[HostVariable] = []
    seen: set[str] = set()
    for kind, declared in (("var", build.variables), ("alias", build.aliases)):
        for v in declared:
            if v.name.upper() in seen:
                continue
            seen.add(v.name.upper())
            variables.append(HostVariable(
                v.name, kind, f"VAR{v.index}", v.index, base + 2 * v.index, WRITE_FUNCTIONS,
                2, "int32", order, "read-write", f"{v.span.file}:{v.span.line}"))
    by_index = {v.index: v.name for v in variables}
    writes = _writes(build, by_index)
    programs = []
    for image in build.programs:
        program, slot = image.program, image.placement.slot
        mp = program.kind == "mp"
        lines = tuple(HostLine(lf.first_slot_line, max(1, lf.line.command.line_cost),
                               lf.line.span.file, lf.line.span.line, lf.line.span.col)
                      for lf in image.lines)
        close = image.close_span
        programs.append(HostProgram(
            program.name or "", program.kind, slot, f"{program.span.file}:{program.span.line}",
            CALL_REGISTER if mp else None, "16" if mp else "",
            tuple(sorted(writes.get((program.kind, slot), set()))), lines,
            (close.file, close.line, close.col)))
    return HostView(FAMILY, build.build_id(), build.word_order, programs, variables,
                    list(consts))


def _writes(build: BuildResult, names: dict[int, str]) -> dict[tuple[str, int], set[str]]:
    """Per program, the declared variables it writes, or a program it calls writes (the
    profile's [host] writes: which operand of which command names the variable written)."""
    table = {str(k): int(v) for k, v in _profile().raw["host"]["writes"].items()}
    own: dict[tuple[str, int], set[str]] = {}
    slots = {(i.program.name or "").upper(): i.placement.slot for i in build.programs
             if i.program.kind == "mp" and i.program.name}
    calls: dict[tuple[str, int], set[int]] = {}
    for image in build.programs:
        key = (image.program.kind, image.placement.slot)
        own[key], calls[key] = set(), set()
        for lf in image.lines:
            short = lf.line.command.short_name
            at = table.get(short)
            ops = lf.line.operands
            if at is not None and at < len(ops) and isinstance(ops[at], VarRef):
                ref = ops[at]
                assert isinstance(ref, VarRef)
                if ref.index in names:
                    own[key].add(names[ref.index])
            for op in ops:
                if short == "MP_CALL" and isinstance(op, ProgramRef):
                    slot = op.slot if op.slot is not None else slots.get((op.name or "").upper())
                    if slot is not None:
                        calls[key].add(slot)
    result: dict[tuple[str, int], set[str]] = {}
    for key in own:
        found, todo, done = set(own[key]), list(calls[key]), set()
        while todo:
            slot = todo.pop()
            if slot in done or ("mp", slot) not in own:
                continue
            done.add(slot)
            found |= own[("mp", slot)]
            todo += calls[("mp", slot)]
        result[key] = found
    return result


def compile_view(paths: list[Path], options: Options) -> tuple[BuildResult, HostView]:
    """Build the sources (diagnostics in the result) and the host's view of the build."""
    sink = DiagnosticSink()
    sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes)
    lowering = Lowering()
    build = compile_sources(paths, sources, sink, options, lowering)
    consts: list[HostConst] = []
    scope = lowering.scope
    if scope is not None:
        for key, decl in scope.const_exprs.items():
            value = scope.const_values.get(key)
            if value is not None:
                consts.append(HostConst(decl.name, value,
                                        f"{decl.name_span.file}:{decl.name_span.line}"))
    return build, view_of(build, consts)


def load_view(path: Path) -> HostView:
    """A host view from a file: what `mpc export --format json` wrote, or an image JSON
    (programs and build id only: an image does not carry the declared variables).
    ValueError / OSError say why not."""
    data = read_json_file(path, errors="strict")
    if isinstance(data, dict) and data.get("format") == "mplang-host/1":
        return HostView.from_json(data)
    from mplang.m8194h.flash.image import ImageError, load_image

    try:
        image = load_image(path)
    except ImageError as exc:
        raise ValueError(str(exc)) from None
    programs = []
    for p in image.programs:
        first = p.lines[0] if p.lines else None
        source = f"{p.source or path}:{first}" if first is not None else str(p.source or path)
        mp = p.kind == "mp"
        programs.append(HostProgram(p.name or "", p.kind, p.slot, source,
                                    CALL_REGISTER if mp else None, "16" if mp else ""))
    return HostView(FAMILY, image.build_id or "", image.word_order, programs)


def runtime_code(device_code: int) -> str:
    """The run-time code (`R103`) whose device side is execution error `device_code`."""
    wanted = f"execution error {device_code:#04x} "
    return next((rule.code for rule in RUNTIME_RULES.values()
                 if rule.device.startswith(wanted)), "R104")


def located(view: HostView, error: Sequence[int]) -> ExecutionError:
    """Registers 115-119 as an ExecutionError at the source line of the view's program."""
    mp_no, isr_no, _command, slot_line, code = (int(v) for v in error)
    kind, slot = ("mp", mp_no) if mp_no else ("isr", isr_no)
    label = f"{kind.upper()}{slot}"
    texts = _profile().raw.get("execution_errors", {})
    message = next((str(t) for k, t in texts.items() if _code_key(k) == code),
                   f"execution error {code:#04x}")
    program = next((p for p in view.programs if p.kind == kind and p.slot == slot), None)
    file = line = column = None
    if program is not None:
        label += f" {program.name}".rstrip()
        place = next((x for x in program.lines if x.first <= slot_line < x.first + x.cost),
                     None)
        if place is not None:
            file, line, column = place.file, place.line, place.column
        elif program.end is not None:
            file, line, column = program.end
    return ExecutionError(runtime_code(code), message, file, line, code, label, slot_line,
                          column)


def _code_key(key: str) -> int | None:
    try:
        return int(key, 0)
    except ValueError:
        return None


class ModbusHost:
    """One M8194H spoken to in a build's names: `check` before anything is written, then
    variables, calls, waits, axes. Use as `async with ModbusHost(endpoint, md) as host:`."""

    def __init__(self, endpoint: Endpoint, identity: mf.MdRange | None) -> None:
        self.link = DeviceLink(endpoint)
        self.identity = identity
        self.order: int | None = None
        self._one_at_a_time = asyncio.Lock()  # the link sends one request at a time

    async def __aenter__(self) -> ModbusHost:
        try:
            await self.link.open()
        except LinkUnavailable as exc:
            raise HostLinkError(str(exc), reached=False) from None
        return self

    async def _guarded(self, request: Awaitable[T]) -> T:
        """A request (never two at once, whatever the caller gathers), its link failures and
        refusals as HostLinkError."""
        try:
            async with self._one_at_a_time:
                return await request
        except LinkError as exc:
            raise HostLinkError(str(exc)) from None
        except DeviceException as exc:
            raise HostLinkError(f"{self.describe()}: {exc}", refused=True) from None

    async def __aexit__(self, *_exc: object) -> None:
        self.link.close()

    def describe(self) -> str:
        return self.link.endpoint.describe()

    async def word_order(self) -> int:
        """Holding register 14, read once per connection."""
        if self.order is None:
            (self.order,) = await self._guarded(self.link.read_holding(WORD_ORDER_REGISTER, 1))
        return self.order

    async def held_build(self) -> tuple[str | None, str]:
        """The build id the device's manifest vouches for (None, and why, when none)."""
        if self.identity is None:
            return None, "no build manifest range (--no-identity)"
        order = await self.word_order()
        try:
            manifest = await self._guarded(mf.read_manifest(self.link, self.identity, order))
        except mf.ManifestError as exc:
            return None, f"{self.identity}: {exc}"
        span = await self._guarded(self.link.read_input(STATE_REGISTER, STATE_SPAN))
        if span[0] != 0 or list(manifest.status) != span[10:15]:
            return manifest.build_id, ("the download status (input registers 110-114) "
                                       "changed since the manifest was written: a program "
                                       "may have been downloaded by something else")
        return manifest.build_id or None, ""

    async def check(self, view: HostView) -> None:
        """BuildMismatch unless the device holds `view`'s build; reads only."""
        held, why = await self.held_build()
        if held != view.build_id or why:
            raise BuildMismatch(held, view.build_id, why)

    async def read(self, var: HostVariable) -> int:
        words = await self._guarded(self.link.read_holding(var.register, var.words))
        if var.words == 2:
            return join32(words, await self.word_order())
        return words[0]

    async def write(self, var: HostVariable, value: int) -> None:
        """BadValue when the value does not fit the variable's type (nothing written)."""
        var.check(value)
        words = split32(value, await self.word_order()) if var.words == 2 else [value]
        await self._guarded(self.link.write_holding(var.register, words))

    async def running(self) -> int:
        """The MP number running now (holding register 8), 0 when none."""
        (number,) = await self._guarded(self.link.read_holding(CALL_REGISTER, 1))
        return int(number)

    async def last_error(self) -> tuple[int, ...]:
        """Input registers 115-119 (all 0: no execution error since power on)."""
        span = await self._guarded(self.link.read_input(STATE_REGISTER, STATE_SPAN))
        return tuple(span[15:20])

    async def start(self, program: HostProgram) -> None:
        """Write the MP's number to holding register 8, once (a call acts: never repeated)."""
        if program.register is None:
            raise ValueError(f"{program.device_name} is an interrupt routine: the host "
                             "cannot call it")
        await self._guarded(self.link.write_once(program.register, [program.slot]))

    async def wait(self, timeout: float | None) -> float:
        """Until no MP runs; the seconds it took. WaitTimeout past `timeout`."""
        poll = float(_profile().raw["host"]["poll_s"])
        began = time.monotonic()
        while await self.running():
            waited = time.monotonic() - began
            if timeout is not None and waited >= timeout:
                raise WaitTimeout(f"the program still runs after {timeout:g} s")
            await asyncio.sleep(poll)
        return time.monotonic() - began

    async def axes(self) -> dict[str, dict[str, Any]]:
        """Per axis: logical position (LP, input 26 + 2n) and whether it stopped (58 + n)."""
        count = STOPPED_FIRST + len(AXES) - LP_FIRST
        regs = await self._guarded(self.link.read_input(LP_FIRST, count))
        order = await self.word_order()
        out = {}
        for n, name in enumerate(AXES):
            stopped = regs[STOPPED_FIRST - LP_FIRST + n] == 1
            out[name] = {"position": join32(regs[2 * n:2 * n + 2], order),
                         "state": "stopped" if stopped else "moving"}
        return out

