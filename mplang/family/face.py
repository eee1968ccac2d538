"""The one face every controller family shows (`mplang.m8194h`, `mplang.fatek`,
`mplang.csim`): what `mpc` and the tools call, so that no command asks which family it is
talking to.

A family package satisfies `Family` as a module: upper-case constants read as properties,
functions as methods. The build side is the same for all: `check_native` for the family's
own listings (`SUFFIXES`), `compile_mp` for `.mp` sources, a `FamilyBuild` that renders
itself in `FORMATS`, and `run_build` on the family's virtual controller giving a
`FamilyRun`. The device side says what the family can reach: `TRANSPORTS` (empty, with
`NO_TRANSPORT` saying why), `serve` (a virtual device for `mpc sim`) and `disassemble`
(an image back to `.mp`) where the family has them, `None` where it has not.

This module imports no family: the families import it (for the shared errors and request
types), and the registry (`mplang.family.registry`) finds them by name.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Mapping, Sequence
from contextlib import AbstractAsyncContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from mplang.ir.unit import Options
from mplang.lang.diagnostics import Diagnostic, Span
from mplang.lang.record import FrozenRecord

if TYPE_CHECKING:  # named in signatures only: a lint or a build does not load the run,
    # debug and host sides (imported by the commands that use them)
    from mplang.family.debug import DebugStart
    from mplang.family.hostview import (
        ExecutionError,
        HostProgram,
        HostValue,
        HostVariable,
        HostView,
    )
    from mplang.family.run_error import RunError
    from mplang.family.trace import Trace
    from mplang.family.watch import Watch

T = TypeVar("T")


class RunSetupError(ValueError):
    """The build does not load into the family's virtual controller."""


class NoSuchProgram(RunSetupError):
    """`--call` names a program that is not in the build."""


class BadImage(ValueError):
    """An image file a family cannot read back; the message starts with the place."""


class MachineError(ValueError):
    """A machine file (`--machine FILE`, an mpc.toml's `[machine]`) that cannot be used;
    the message starts with file:line."""


class Disassembled(Protocol):
    """What `disassemble` returns: `.mp` source, and what could not be carried over
    exactly (empty when the source rebuilds to the very same frames)."""

    @property
    def text(self) -> str: ...

    @property
    def problems(self) -> list[str]: ...


class ServiceError(Exception):
    """A virtual device cannot be served as asked. `kind`: "usage" (the request does not
    fit the family: the command line is wrong), "memory" (the memory file cannot be read or
    written), "refused" (the device refused the preloaded build), "transport" (the port or
    serial line cannot be opened or failed)."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


Companion = Callable[[str, int], AbstractAsyncContextManager[None]]
"""Something served beside a virtual device for as long as it runs (`mpc sim --monitor`):
given the host and port its Modbus TCP service listens on; raises `ServiceError` when it
cannot start."""


class ServeRequest(FrozenRecord):
    """What `mpc sim` asks of a family's virtual device. Options a family has no use for are
    refused before it is asked (`SERVE_OPTIONS`); the rest it checks itself."""

    tcp: tuple[str, int] | None
    serial: str | None
    unit: int
    baud: int
    parity: str
    stopbits: int
    speed: float
    memory: Path | None
    duration: float | None
    verbose: bool
    word_order: int | None
    describe: str  # the family (and target) in words, for messages
    companion: Companion | None  # started once Modbus TCP listens (`mpc sim --monitor`)
    machine: object | None  # what the family's `load_machine` returned, if given
    devices: int  # `mpc sim --devices N`: N devices from one process
    _fields = __match_args__ = ("tcp", "serial", "unit", "baud", "parity", "stopbits", "speed",
                                "memory", "duration", "verbose", "word_order", "describe",
                                "companion", "machine", "devices")

    def __init__(self, tcp: tuple[str, int] | None, serial: str | None, unit: int, baud: int,
                 parity: str, stopbits: int, speed: float, memory: Path | None,
                 duration: float | None, verbose: bool, word_order: int | None,
                 describe: str, companion: Companion | None = None,
                 machine: object | None = None, devices: int = 1) -> None:
        self.__dict__.update(tcp=tcp, serial=serial, unit=unit, baud=baud, parity=parity,
                             stopbits=stopbits, speed=speed, memory=memory, duration=duration,
                             verbose=verbose, word_order=word_order, describe=describe,
                             companion=companion, machine=machine, devices=devices)


class CommandError(Exception):
    """A family cannot do what the command asks, for a reason the command line or the input
    carries: `kind` "usage" (exit 2) or "input" (exit 3), or "leased" (a dashboard write
    refused while another client holds the device's download lease: HTTP 409); `param`
    names the option to blame, if one is."""

    def __init__(self, kind: str, message: str, param: str | None = None) -> None:
        super().__init__(message)
        self.kind = kind
        self.param = param


class FlashTarget(Protocol):
    """One device to flash, as a project file or the command line describes it
    (`mplang.tools.project.Target`)."""

    @property
    def name(self) -> str: ...
    @property
    def host(self) -> str | None: ...
    @property
    def port(self) -> int: ...
    @property
    def serial(self) -> str | None: ...
    @property
    def unit(self) -> int: ...
    @property
    def baud(self) -> int: ...
    @property
    def parity(self) -> str: ...
    @property
    def stopbits(self) -> int: ...
    @property
    def timeout(self) -> float | None: ...
    @property
    def retries(self) -> int | None: ...
    @property
    def word_order(self) -> int | None: ...
    @property
    def target(self) -> str | None: ...
    @property
    def image(self) -> Path | None: ...
    @property
    def sources(self) -> Sequence[Path]: ...
    @property
    def span(self) -> Span | None: ...

    def address(self) -> str: ...


class FlashJob(FrozenRecord):
    """What `mpc flash` asks of a family: the devices (all of this family), what to build
    for them, and how. `timeout` and `retries` are the command line's when it gave them
    (None: each device's own, then the project's `[flash]`, then the defaults)."""

    devices: Sequence[FlashTarget]
    paths: list[Path]  # FILE... or the project's sources, for devices without their own
    options: Options
    werror: bool
    word_order_fixed: bool  # --word-order or the project's word-order was given
    dry_run: bool
    as_json: bool
    force: bool
    set_word_order: bool
    record: Path | None  # --record, else the project's [flash] record
    timeout: float | None
    retries: int | None
    settings_timeout: float | None  # the project's [flash] values
    settings_retries: int | None
    settings_set_word_order: bool
    fleet: bool  # --fleet: every device at once, a table at the end
    stop_running: bool  # stop a running program before writing (else: refuse)
    identity: str | bool | None  # where the build manifest goes: a range, False
    # (never), None (the family's default)
    identity_where: str | None  # "FILE:LINE: [flash] identity" when it came from there
    wait_lease: float  # --wait-lease: seconds to wait for another client's lease
    _fields = __match_args__ = ("devices", "paths", "options", "werror", "word_order_fixed",
                                "dry_run", "as_json", "force", "set_word_order", "record",
                                "timeout", "retries", "settings_timeout", "settings_retries",
                                "settings_set_word_order", "fleet", "stop_running", "identity",
                                "identity_where", "wait_lease")

    def __init__(self, devices: Sequence[FlashTarget], paths: list[Path], options: Options,
                 werror: bool, word_order_fixed: bool, dry_run: bool, as_json: bool,
                 force: bool, set_word_order: bool, record: Path | None, timeout: float | None,
                 retries: int | None, settings_timeout: float | None,
                 settings_retries: int | None, settings_set_word_order: bool, fleet: bool,
                 stop_running: bool = False, identity: str | bool | None = None,
                 identity_where: str | None = None, wait_lease: float = 0.0) -> None:
        self.__dict__.update(devices=devices, paths=paths, options=options, werror=werror,
                             word_order_fixed=word_order_fixed, dry_run=dry_run,
                             as_json=as_json, force=force, set_word_order=set_word_order,
                             record=record, timeout=timeout, retries=retries,
                             settings_timeout=settings_timeout,
                             settings_retries=settings_retries,
                             settings_set_word_order=settings_set_word_order, fleet=fleet,
                             stop_running=stop_running, identity=identity,
                             identity_where=identity_where, wait_lease=wait_lease)


class StatusJob(FrozenRecord):
    """What `mpc status` asks of a family: one device, and optionally what would be flashed
    into it (FILE..., an image, or the project's sources) to compare with."""

    device: FlashTarget
    paths: list[Path]
    options: Options
    word_order_fixed: bool
    as_json: bool
    timeout: float
    retries: int
    identity: str | bool | None  # as FlashJob.identity
    identity_where: str | None
    fleet: bool  # --fleet: every device of `devices`, a table at the end
    devices: Sequence[FlashTarget]  # the fleet (`device` is its first)
    jobs: int  # devices read at once in a fleet
    _fields = __match_args__ = ("device", "paths", "options", "word_order_fixed", "as_json",
                                "timeout", "retries", "identity", "identity_where", "fleet",
                                "devices", "jobs")

    def __init__(self, device: FlashTarget, paths: list[Path], options: Options,
                 word_order_fixed: bool, as_json: bool, timeout: float, retries: int,
                 identity: str | bool | None = None, identity_where: str | None = None,
                 fleet: bool = False, devices: Sequence[FlashTarget] = (),
                 jobs: int = 8) -> None:
        self.__dict__.update(device=device, paths=paths, options=options,
                             word_order_fixed=word_order_fixed, as_json=as_json,
                             timeout=timeout, retries=retries, identity=identity,
                             identity_where=identity_where, fleet=fleet, devices=devices,
                             jobs=jobs)


class DeviceUnreachable(Exception):
    """A live device cannot be read just now (no connection, no answer, a refused read):
    the watcher shows it and tries again."""


class WatchJob(FrozenRecord):
    """What `mpc monitor` (and `mpc sim --monitor`) asks of a family: one device to watch
    live, and the build it holds if the sources are known (for declared names and source
    lines)."""

    device: FlashTarget
    build: FamilyBuild | None
    timeout: float
    retries: int
    _fields = __match_args__ = ("device", "build", "timeout", "retries")

    def __init__(self, device: FlashTarget, build: FamilyBuild | None, timeout: float,
                 retries: int) -> None:
        self.__dict__.update(device=device, build=build, timeout=timeout, retries=retries)


class LiveDevice(Protocol):
    """One device watched live: `read` gives the state as JSON-ready data (the fields of
    docs/monitor.md) or raises `DeviceUnreachable`; `act` carries out one write ("call",
    "set_var", "stop", "emergency_stop", "clear_emergency") and says what it did, raising
    `CommandError` for a request that cannot be carried out and `DeviceUnreachable` when
    the device does not answer."""

    async def read(self) -> dict[str, Any]: ...

    async def act(self, action: str, args: Mapping[str, Any]) -> str: ...

    def close(self) -> None: ...


class StatusUI(Protocol):
    """Where `mpc status` prints, and how a build's diagnostics are reported."""

    def say(self, text: str) -> None: ...

    def out(self, text: str) -> None: ...

    def checked(self, build: FamilyBuild) -> None: ...


class Progress(Protocol):
    """A running flash as the user sees it: lines, and (on a terminal) a progress bar fed
    by the reports the flash keeps."""

    def say(self, text: str) -> None: ...

    def drive(self, work: Callable[[], Awaitable[T]], fallback: Callable[[], T]) -> T:
        """Run the coroutine `work()` while the display redraws; Ctrl-C and SIGTERM cancel
        it, and `fallback()` gives what it left."""
        ...


class FlashUI(Protocol):
    """What the command gives a family's flash: where lines go, how a build's diagnostics
    are reported, and a progress display."""

    def say(self, text: str) -> None:
        """A line on standard error (`mpc flash: ...`)."""
        ...

    def out(self, text: str) -> None:
        """Standard output (JSON summaries, dry-run plans)."""
        ...

    def checked(self, build: FamilyBuild) -> None:
        """Report the build's diagnostics; end the command (exit 1) if it has errors, or
        warnings with --werror."""
        ...

    def progress(self, reports: Callable[[], Sequence[Any]]) -> Progress: ...


FLASH_OUTCOMES = ("verified", "no-port", "no-device", "rejected", "unverified",
                  "interrupted", "mixed", "leased")
"""What a flash can end in; the command maps each to its exit code."""


class FamilyBuild(Protocol):
    """What `check_native` and `compile_mp` return."""

    @property
    def diagnostics(self) -> list[Diagnostic]: ...

    @property
    def ok(self) -> bool: ...

    @property
    def programs(self) -> Sequence[object]: ...

    def render(self, fmt: str) -> str: ...

    def to_json(self) -> Mapping[str, object]: ...


class FamilyRun(Protocol):
    """What `run_build` returns: the `mpc run --json` summary and the run sampled over
    time (`trace`, None when the run was not sampled)."""

    @property
    def called(self) -> str: ...

    @property
    def finished(self) -> bool: ...

    @property
    def error(self) -> str | None: ...

    @property
    def failure(self) -> RunError | None:
        """The error as a run-time finding at its source line (`mplang.family.run_error`)."""
        ...

    @property
    def time_s(self) -> float: ...

    @property
    def trace(self) -> Trace | None: ...

    @property
    def warnings(self) -> Sequence[str]:
        """What the run did not simulate (`file:line: warning: ...`): `mpc run` prints them."""
        ...

    def headline_detail(self, controller: str) -> str:
        """The end of `mpc run`'s headline after the simulated time (", 12 lines", " on
        the virtual CSIM"); `controller` names the family and target in words."""
        ...

    def plot_title(self, controller: str, sources: str) -> str:
        """The heading of `mpc plot`: the program that ran, and where (`sources`: the files
        built, `controller`: as for `headline_detail`)."""
        ...

    def to_json(self) -> Mapping[str, object]: ...


class HostDevice(Protocol):
    """One device spoken to in a build's names (`mpc call`, `mpc var`, `mplang.host`), as an
    async context manager that opens and closes the connection. Every method raises the
    family's link errors as `HostLinkError`."""

    async def __aenter__(self) -> HostDevice: ...

    async def __aexit__(self, *exc: object) -> None: ...

    def describe(self) -> str: ...

    async def word_order(self) -> int:
        """The word order of the device's 32-bit values (what a build for it uses)."""
        ...

    async def check(self, view: HostView) -> None:
        """Raise `BuildMismatch` unless the device holds `view`'s build; writes nothing."""
        ...

    async def read(self, var: HostVariable) -> HostValue:
        """An int, or a float for a real variable (`HostVariable.type` float32)."""
        ...

    async def write(self, var: HostVariable, value: Any) -> None:
        """`value` as `var.check` passed it: an int, or a float for a real variable (typed
        Any so that a family whose variables are all integers may take an int)."""
        ...

    async def running(self) -> int:
        """The number of the program running now, 0 when none."""
        ...

    async def last_error(self) -> tuple[int, ...]:
        """The device's record of its last execution error (all 0: none)."""
        ...

    async def start(self, program: HostProgram) -> None: ...

    async def wait(self, timeout: float | None) -> float:
        """Until no program runs (raising `WaitTimeout` past `timeout`); the seconds."""
        ...

    async def axes(self) -> dict[str, dict[str, Any]]:
        """Per axis name: "position" and "state" ("moving" or "stopped")."""
        ...


class HostSide(Protocol):
    """What a family offers a host program (`Family.host`)."""

    def build_view(self, paths: list[Path], options: Options) -> tuple[FamilyBuild, HostView]:
        """Build the sources (diagnostics in the build) and the host's view of the build."""
        ...

    def load_view(self, path: Path) -> HostView:
        """A view from a file (`mpc export --format json`, an image): ValueError, OSError."""
        ...

    def device(self, target: FlashTarget, identity: str | bool | None, timeout: float,
               retries: int) -> HostDevice:
        """One device (not yet open); `identity` the build manifest's place as `mpc flash`
        takes it (False: none)."""
        ...

    def located(self, view: HostView, error: Sequence[int]) -> ExecutionError:
        """The device's record of an execution error at its source line in `view`."""
        ...


Say = Callable[[str], None]
"""Where a virtual device reports what it does (one line at a time)."""


class Family(Protocol):
    """A family package as a module."""

    @property
    def TITLE(self) -> str: ...

    @property
    def TARGETS(self) -> tuple[str, ...]: ...

    @property
    def SUFFIXES(self) -> tuple[str, ...]: ...

    @property
    def FORMATS(self) -> tuple[str, ...]: ...

    @property
    def DEFAULT_FORMAT(self) -> str: ...

    @property
    def POSITION_UNIT(self) -> str: ...

    @property
    def TRANSPORTS(self) -> tuple[str, ...]: ...

    @property
    def NO_TRANSPORT(self) -> str: ...

    @property
    def PROTOCOL(self) -> str:
        """What the device speaks on its transports: "modbus", "rs232-ascii", or "" where
        nothing reaches it."""
        ...

    @property
    def BUILD_OPTIONS(self) -> frozenset[str]:
        """The build options (`--word-order`, ...) beyond the common ones that this family
        uses; the others are refused when given, and noted when a project file sets them."""
        ...

    @property
    def SERVE_OPTIONS(self) -> frozenset[str]:
        """`mpc sim` options beyond the common ones that this family uses."""
        ...

    @property
    def FLASH_OPTIONS(self) -> frozenset[str]:
        """`mpc flash` options beyond the common ones that this family uses."""
        ...

    @property
    def NoSuchProgram(self) -> type[Exception]: ...

    @property
    def RunSetupError(self) -> type[Exception]: ...

    @property
    def serve(self) -> Callable[[FamilyBuild | None, ServeRequest, Say], None] | None:
        """`mpc sim`: serve the virtual device until stopped (raising `ServiceError`), or
        None where the family has no device service."""
        ...

    @property
    def flash_devices(self) -> Callable[[FlashJob, FlashUI], str] | None:
        """`mpc flash`: download, verify and report (one of `FLASH_OUTCOMES`), raising
        `CommandError` for what the job asks wrongly; None where nothing can reach the
        family's devices (`NO_TRANSPORT` says why, `FLASH_INSTEAD` what to do)."""
        ...

    @property
    def status_device(self) -> Callable[[StatusJob, StatusUI], str] | None:
        """`mpc status`: read one device (and compare it with a build), print it, and say
        "in-sync", "out-of-sync" or "no-device"; None where the family has no status."""
        ...

    @property
    def watch(self) -> Callable[[WatchJob], LiveDevice] | None:
        """`mpc monitor`: a live view of one device (`LiveDevice`), None where the family
        has none (`NO_TRANSPORT` or its `status_device` being None say why)."""
        ...

    @property
    def FLASHES_FLEETS(self) -> bool:
        """Whether `flash` takes many devices at once (`mpc flash --fleet`)."""
        ...

    @property
    def FLASH_INSTEAD(self) -> str:
        """For a family that cannot be flashed: what to do instead (`{target}` stands for
        the target); "" for the others."""
        ...

    @property
    def disassemble(self) -> Callable[[Path, range], Disassembled] | None:
        """`mpc disasm`: an image file of the family (its temporaries pool given) back to
        `.mp` (raising `BadImage` or `OSError`), or None where the family has no image."""
        ...

    @property
    def debug(self) -> DebugStart | None:
        """`mpc dap`: one program of a build on a fresh virtual controller, stopped before
        its first line (`mplang.family.debug`), or None where the family's virtual controller
        cannot stop at a source line (`NO_DEBUG` says why)."""
        ...

    @property
    def NO_DEBUG(self) -> str:
        """Why the family cannot be debugged; "" for a family that can."""
        ...

    @property
    def load_machine(self) -> Callable[[Path, bool], object] | None:
        """The simulated machine: read and check the `[machine]` table of a file (a
        machine file, or with the flag an mpc.toml), raising `MachineError`; what it returns
        goes to `run_build` and `ServeRequest.machine`. None where the family's virtual
        device has no machine to describe (`NO_MACHINE` says why)."""
        ...

    @property
    def NO_MACHINE(self) -> str:
        """Why `--machine` does not apply to this family; "" where it does."""
        ...

    @property
    def host(self) -> HostSide | None:
        """`mpc call`, `mpc var`, `mpc export` and `mplang.host`: a build's names on a
        device, or None where a host cannot reach the family's programs and variables
        (`NO_HOST` says why)."""
        ...

    @property
    def NO_HOST(self) -> str:
        """Why a host cannot use this family's names on a device; "" where it can."""
        ...

    def check_native(self, paths: list[Path], target: str | None = None) -> FamilyBuild: ...

    def compile_mp(self, paths: list[Path], options: Options, target: str, *,
                   texts: dict[Path, str] | None = None) -> FamilyBuild:
        """`texts`: contents read instead of some files (by resolved path): an editor's
        buffer, `mpc lint -`'s standard input."""
        ...

    def run_build(self, build: Any, call: str | None, max_time: float, *,
                  sample_period: float | None = ..., machine: object | None = ...,
                  watch: Watch | None = ...) -> FamilyRun:
        """Run one program on the family's virtual controller (on the machine its
        `load_machine` read, if given); an infinite `max_time` is no limit, and `watch` sees
        the run as it goes and may stop it (`mplang.family.watch`)."""
        ...
