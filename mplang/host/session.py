"""The async core of `mplang.host` (and of `mpc call` / `mpc var`): one device, one build,
spoken to in the build's names through the family's host side (`Family.host`).

Opening reads the device's word order, builds the sources for it (or reads an image or an
export), and, when asked to check, refuses with `BuildMismatch` before anything is written
if the device does not hold that build.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mplang.family.hostview import (
    ExecutionError,
    HostError,
    HostProgram,
    HostValue,
    HostView,
    ProgramRunning,
)
from mplang.ir.unit import Options

if TYPE_CHECKING:
    from mplang.family.face import Family, FamilyBuild, HostDevice, HostSide
    from mplang.tools.project import Target


class BuildFailed(HostError):
    """The sources do not build; `build` holds the diagnostics."""

    def __init__(self, build: FamilyBuild) -> None:
        self.build = build
        errors = [d for d in build.diagnostics if d.severity.value == "error"]
        first = errors[0] if errors else None
        where = f"{first.span.file}:{first.span.line}: {first.message}" if first else ""
        super().__init__(f"the sources do not build ({len(errors)} error(s)): {where}")


class NoHost(HostError):
    """The family has no host side (`Family.NO_HOST` says why)."""


@dataclass(frozen=True)
class Plan:
    """What to open: the device, its family, and where the build comes from (sources or one
    image / export file)."""

    family: Family
    device: Target
    paths: tuple[Path, ...] = ()
    image: Path | None = None
    options: Options = Options()
    word_order_fixed: bool = False
    identity: str | bool | None = None
    timeout: float = 1.0
    retries: int = 3

    @property
    def side(self) -> HostSide:
        side = self.family.host
        if side is None:
            raise NoHost(f"{self.family.TITLE}: {self.family.NO_HOST}")
        return side


@dataclass(frozen=True)
class CallResult:
    """What `call` saw: the program, the declared variables it writes (with the values they
    hold when it ended; empty without waiting), and how long it took."""

    program: HostProgram
    build_id: str
    vars: dict[str, HostValue]
    time_ms: float | None
    error: ExecutionError | None = None
    note: str = ""  # what the device's error record cannot tell (see `_new_error`)

    def to_json(self) -> dict[str, Any]:
        """`mpc call --json`."""
        name = self.program.name or self.program.device_name
        return {"program": name, "slot": self.program.device_name, "build_id": self.build_id,
                "vars": self.vars, "error": None if self.error is None else
                self.error.to_json(), "time_ms": self.time_ms}


@dataclass(frozen=True)
class Axis:
    """One axis as read: its logical position (pulses; a CSIM's units, a real) and
    "moving" / "stopped" (a CSIM: "running" while a program runs, see docs/host.md)."""

    name: str
    position: HostValue
    state: str


class AsyncController:
    """One device and one build, spoken to by name. `async with` opens (and checks)."""

    def __init__(self, plan: Plan, check: bool = True) -> None:
        self.plan = plan
        self.check = check
        self.side = plan.side
        self.device: HostDevice = self.side.device(plan.device, plan.identity, plan.timeout,
                                                   plan.retries)
        self._view: HostView | None = None
        self.build: FamilyBuild | None = None

    async def __aenter__(self) -> AsyncController:
        await self.open()
        return self

    async def __aexit__(self, *_exc: object) -> None:
        await self.close()

    async def open(self) -> None:
        """Connect, build for the device's word order, and check the device's build."""
        await self.device.__aenter__()
        try:
            order = await self.device.word_order()
            self._view = self._make_view(order)
            if self.check:
                await self.device.check(self._view)
        except BaseException:
            await self.device.__aexit__(None, None, None)
            raise

    async def close(self) -> None:
        await self.device.__aexit__(None, None, None)

    def _make_view(self, order: int) -> HostView:
        plan = self.plan
        if plan.image is not None:
            try:
                return self.side.load_view(plan.image)
            except OSError as exc:
                raise HostError(f"cannot read {plan.image}: {exc.strerror or exc}") from None
            except ValueError as exc:
                raise HostError(f"{plan.image}: {exc}") from None
        options = plan.options if plan.word_order_fixed else plan.options.replace(
            word_order=order)
        build, view = self.side.build_view(list(plan.paths), options)
        self.build = build
        if not build.ok:
            raise BuildFailed(build)
        return view

    @property
    def view(self) -> HostView:
        if self._view is None:
            raise HostError("the controller is not open")
        return self._view

    @property
    def build_id(self) -> str:
        return self.view.build_id

    async def read_var(self, name: str) -> HostValue:
        return await self.device.read(self.view.variable(name))

    async def write_var(self, name: str, value: HostValue) -> None:
        """`BadValue` (nothing written) when the variable's type cannot hold `value`."""
        var = self.view.variable(name)
        await self.device.write(var, var.check(value))

    async def write_vars(self, values: Mapping[str, HostValue]) -> None:
        """Every name and value is checked before the first write, so a wrong one writes
        nothing."""
        found = [(var, var.check(value)) for var, value in
                 ((self.view.variable(name), value) for name, value in values.items())]
        for var, value in found:
            await self.device.write(var, value)

    async def read_vars(self, names: list[str] | None = None) -> dict[str, HostValue]:
        """The named (default: every declared) variables, by declared name."""
        chosen = [self.view.variable(n) for n in names] if names else self.view.variables
        return {v.name: await self.device.read(v) for v in chosen}

    async def running(self) -> bool:
        return bool(await self.device.running())

    async def axes(self) -> dict[str, Axis]:
        return {name: Axis(name, a["position"], str(a["state"]))
                for name, a in (await self.device.axes()).items()}

    async def errors(self) -> list[ExecutionError]:
        """The execution error the device records (its last one since power on), if any."""
        record = await self.device.last_error()
        return [self.side.located(self.view, record)] if any(record) else []

    async def call(self, name: str, wait: bool = True, timeout: float | None = None
                   ) -> CallResult:
        """Start a program by declared name or `MPn`; with `wait`, until it ends: the
        declared variables it writes; `ExecutionError` at its source line when it failed,
        `WaitTimeout` past `timeout`."""
        result = await self.call_result(name, wait, timeout)
        if result.error is not None:
            raise result.error
        return result

    async def call_result(self, name: str, wait: bool = True, timeout: float | None = None
                          ) -> CallResult:
        """`call`, with an execution error in the result instead of raised."""
        program = self.view.program(name)
        running = await self.device.running()
        if running:
            raise ProgramRunning(f"{self.view.running_name(running)} is running: the device "
                                 "takes no call until it "
                                 f"ends (wait for it, or stop it), so {program.device_name} "
                                 "was not started")
        before = await self.device.last_error()
        began = time.monotonic()
        await self.device.start(program)
        if not wait:
            return CallResult(program, self.build_id, {}, None)
        await self.device.wait(timeout)
        elapsed = round((time.monotonic() - began) * 1000, 3)
        after = await self.device.last_error()
        error = self._new_error(before, after)
        values = await self.read_vars(list(program.writes)) if program.writes else {}
        note = ""
        if error is None and any(before) and after == before:
            held = self.side.located(self.view, before)
            note = (f"the device recorded execution error {held.code} in {held.slot} "
                    "before this call and keeps only its last one: a failure of this call "
                    "at that very line would look the same")
        return CallResult(program, self.build_id, values, elapsed, error, note)

    async def wait(self, timeout: float | None = None) -> None:
        """Until no program runs (`WaitTimeout` past `timeout`)."""
        before = await self.device.last_error()
        await self.device.wait(timeout)
        error = self._new_error(before, await self.device.last_error())
        if error is not None:
            raise error

    def _new_error(self, before: tuple[int, ...], after: tuple[int, ...]
                   ) -> ExecutionError | None:
        """The device's execution error record `after`, when it changed since `before`: the
        device keeps only its last one, so a new error identical to the one it held already
        cannot be told apart from it."""
        if after == before or not any(after):
            return None
        return self.side.located(self.view, after)
