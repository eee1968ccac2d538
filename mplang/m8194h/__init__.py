"""The ICP DAS M8194H back end (ET-M8194H over Modbus TCP, RS-M8194H over Modbus RTU):
linker (`link`), frame encoder (`encode`), the image (`image`), the compiler that puts them
together (`compiler`), image back to `.mp` (`disasm`), vendor-API C to `.mp` (`importc`),
the virtual controller (`sim`, served by `serve`), the Modbus transport (`modbus`) and
flashing (`flash`).

The package satisfies the family face (`mplang.family.face.Family`) like `mplang.fatek` and
`mplang.csim`: `.mp` is its own language, so it has no native listing suffix, and
`check_native` compiles `.mp` with the default options.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from mplang.family.face import FamilyBuild as AnyBuild
from mplang.family.face import (
    FlashJob,
    FlashTarget,
    FlashUI,
    HostDevice,
    HostSide,
    NoSuchProgram,
    RunSetupError,
    Say,
    ServeRequest,
    StatusJob,
    StatusUI,
    WatchJob,
)
from mplang.ir.unit import Options
from mplang.m8194h.compiler import compile_paths
from mplang.m8194h.image import DEFAULT_FORMAT, FORMATS, BuildResult

if TYPE_CHECKING:  # the host view and the watch only when a command uses them
    from mplang.family.hostview import ExecutionError, HostView
    from mplang.family.watch import Watch
    from mplang.m8194h.debugger import Session
    from mplang.m8194h.disasm import Disassembly
    from mplang.m8194h.live import Watcher
    from mplang.m8194h.machine import MachineSetup
    from mplang.m8194h.run import RunReport

TITLE = "M8194H"
TARGETS = ("et", "rs")
SUFFIXES: tuple[str, ...] = ()
POSITION_UNIT = "pulses"
TRANSPORTS = ("tcp", "serial")
NO_TRANSPORT = ""
PROTOCOL = "modbus"
BUILD_OPTIONS = frozenset({"--word-order", "--pins"})
"""The word order of the image (holding register 14) and slot pins (mpc.toml `[slots]`):
the M8194H's alone."""
FLASH_OPTIONS = frozenset({"--unit", "--word-order", "--set-word-order", "--record",
                           "--retries", "--stop-running", "--identity", "--no-identity",
                           "--wait-lease"})
"""`mpc flash` options beyond the common ones: Modbus, image frames, the flash record, the
build manifest in machine data."""
FLASHES_FLEETS = True
FLASH_INSTEAD = ""
NO_DEBUG = ""
NO_MACHINE = ""
NO_HOST = ""
"""`--machine` applies: the virtual controller's sensors and inputs (docs/machine.md)."""
SERVE_OPTIONS = frozenset({"--unit", "--memory", "--word-order", "--devices"})
"""`mpc sim` options beyond the common ones: the RTU address, the macro memory file, the
word order of the virtual controller and a fleet of them (`--devices`)."""

FamilyBuild = BuildResult
if TYPE_CHECKING:
    FamilyRun = RunReport


def __getattr__(name: str) -> object:
    """`FamilyRun` (the run report), imported when asked for: the virtual controller behind
    it is not loaded by the commands that only compile (`mpc build`, `mpc lint`)."""
    if name == "FamilyRun":
        from mplang.m8194h.run import RunReport

        return RunReport
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "BUILD_OPTIONS",
    "DEFAULT_FORMAT",
    "FLASHES_FLEETS",
    "FLASH_INSTEAD",
    "FLASH_OPTIONS",
    "FORMATS",
    "NO_DEBUG",
    "NO_HOST",
    "NO_MACHINE",
    "NO_TRANSPORT",
    "POSITION_UNIT",
    "PROTOCOL",
    "SERVE_OPTIONS",
    "SUFFIXES",
    "TARGETS",
    "TITLE",
    "TRANSPORTS",
    "FamilyBuild",
    "FamilyRun",
    "NoSuchProgram",
    "RunSetupError",
    "check_native",
    "compile_mp",
    "debug",
    "disassemble",
    "flash_devices",
    "host",
    "load_machine",
    "run_build",
    "serve",
    "status_device",
    "watch",
]


def compile_mp(paths: list[Path], options: Options, target: str, *,
               texts: dict[Path, str] | None = None) -> BuildResult:
    """Compile `.mp` sources for `target` ("et" or "rs"); `texts` read instead of files."""
    return compile_paths(paths, options.replace(target=target), texts=texts)


def check_native(paths: list[Path], target: str | None = None) -> BuildResult:
    """The M8194H's own language is `.mp`: compiled with the default options."""
    return compile_mp(paths, Options(), target or TARGETS[0])


def run_build(build: BuildResult, call: str | None, max_time: float, *,
              sample_period: float | None = None, machine: object | None = None,
              watch: Watch | None = None) -> RunReport:
    """Run one MP of the build on a fresh virtual controller (`mplang.m8194h.run`, imported
    when called, as `serve`), on the machine `load_machine` read, if given."""
    from mplang.m8194h.run import run_family

    return run_family(build, call, max_time, sample_period=sample_period, machine=machine,
                      watch=watch)


def load_machine(path: Path, project: bool = False) -> MachineSetup:
    """The simulated machine of a machine file, or of an mpc.toml's `[machine]` table with
    `project` (`mplang.m8194h.machine`, imported when called; docs/machine.md)."""
    from mplang.m8194h import machine as machine_module

    return machine_module.load_machine(path, project=project)


def serve(build: AnyBuild | None, request: ServeRequest, say: Say) -> None:
    """Serve a virtual controller over Modbus (`mplang.m8194h.simulate`). Imported when
    called: the Modbus stack is not loaded for commands that do not serve."""
    from mplang.m8194h import simulate

    simulate.serve(build, request, say)


def disassemble(path: Path, temps: range) -> Disassembly:
    """An image JSON back to `.mp` (`mplang.m8194h.disasm`), imported when called, as
    `serve`."""
    from mplang.m8194h import disasm

    return disasm.disassemble_file(path, temps)


def flash_devices(job: FlashJob, ui: FlashUI) -> str:
    """Download and verify over Modbus (`mplang.m8194h.flashing`), imported when called, as
    `serve`."""
    from mplang.m8194h import flashing

    return flashing.flash(job, ui)


def status_device(job: StatusJob, ui: StatusUI) -> str:
    """Read one device and compare it with a build (`mplang.m8194h.status`), imported when
    called, as `serve`."""
    from mplang.m8194h import status, status_fleet

    if job.fleet:
        return status_fleet.status(job, ui)
    return status.status(job, ui)


def debug(build: object, call: str | None, machine: Path | None, max_time: float) -> Session:
    """`mpc dap`: one MP of the build on a fresh virtual controller, stopped before its first
    line (`mplang.m8194h.debugger`), imported when called, as `serve`."""
    from mplang.m8194h import debugger

    return debugger.start(build, call, machine, max_time)


def watch(job: WatchJob) -> Watcher:
    """A live view of one device for `mpc monitor` (`mplang.m8194h.live`), imported when
    called, as `serve`."""
    from mplang.m8194h import live

    return live.watch(job)


class _HostSide:
    """`Family.host`: a build's names on a device over Modbus (`mplang.m8194h.hostlink`,
    imported when called, as `serve`)."""

    def build_view(self, paths: list[Path], options: Options) -> tuple[AnyBuild, HostView]:
        from mplang.m8194h import hostlink as host_module

        return host_module.compile_view(paths, options)

    def load_view(self, path: Path) -> HostView:
        from mplang.m8194h import hostlink as host_module

        return host_module.load_view(path)

    def device(self, target: FlashTarget, identity: str | bool | None, timeout: float,
               retries: int) -> HostDevice:
        """ValueError for a malformed machine-data range."""
        from mplang.m8194h import hostlink as host_module
        from mplang.m8194h.flash.manifest import DEFAULT_RANGE, parse_range
        from mplang.m8194h.status import endpoint_of

        md = None if identity is False else parse_range(
            identity if isinstance(identity, str) else DEFAULT_RANGE)
        return host_module.ModbusHost(endpoint_of(target, timeout, retries), md)

    def located(self, view: HostView, error: Sequence[int]) -> ExecutionError:
        from mplang.m8194h import hostlink as host_module

        return host_module.located(view, error)


host: HostSide = _HostSide()
