"""The CSIM / SLIM RS232 command set (shared/manuals/004_fd07d4bf40d1e0ce.txt): native
`.csim` scripts, `.mp` compiled with `--target csim`, a virtual CSIM to run them on, and
program download over a serial line. The package satisfies the family face
(`mplang.family.face.Family`, docs/csim.md)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from mplang.csim.build import (
    BUILD_OPTIONS,
    DEFAULT_FORMAT,
    FLASH_INSTEAD,
    FLASH_OPTIONS,
    FLASHES_FLEETS,
    FORMATS,
    NO_TRANSPORT,
    POSITION_UNIT,
    PROTOCOL,
    SERVE_OPTIONS,
    SUFFIXES,
    TARGETS,
    TITLE,
    TRANSPORTS,
    CsimProgram,
    FamilyBuild,
    check_native,
)
from mplang.csim.compile import compile_mp
from mplang.csim.flashing import flash as flash_devices
from mplang.csim.run import FamilyRun, NoSuchProgram, RunSetupError, run_build
from mplang.csim.service import serve
from mplang.csim.status import status as status_device
from mplang.family.face import FlashTarget, HostDevice, HostSide
from mplang.family.hostview import ExecutionError, HostError, HostView
from mplang.ir.unit import Options

disassemble = None
"""No image format to read back: a CSIM lists its program itself (ULP)."""
load_machine = None
NO_MACHINE = ("the virtual CSIM has no limit or home switches to place, and its inputs 1-8 "
              "hold one state for a whole run (docs/csim.md)")
"""No `--machine`: why not, for the command line's refusal."""
debug = None
"""No `mpc dap`: the virtual CSIM runs its command lines with no place to stop (`NO_DEBUG`)."""
NO_DEBUG = ("the virtual CSIM runs its command lines with no place to stop at a source "
            "line; debug the same .mp sources with target et (the virtual M8194H)")
NO_HOST = ""


class _HostSide:
    """`Family.host`: a build's names on a CSIM over its RS232 command set
    (`mplang.csim.hostlink`, imported when called)."""

    def build_view(self, paths: list[Path], options: Options) -> tuple[FamilyBuild, HostView]:
        from mplang.csim import hostlink

        return hostlink.compile_view(paths, options)

    def load_view(self, path: Path) -> HostView:
        from mplang.csim import hostlink

        return hostlink.load_view(path)

    def device(self, target: FlashTarget, identity: str | bool | None, timeout: float,
               retries: int) -> HostDevice:
        """`identity` and `retries` do not apply: a CSIM holds no manifest, and a question
        on its line is asked once (the command line refuses --identity for a CSIM)."""
        from mplang.csim import hostlink

        if target.serial is None:
            raise HostError("a CSIM is reached over its RS232 line: give serial=PORT "
                            "(--serial PORT); tcp is Modbus TCP, for the ET-M8194H")
        return hostlink.CsimHost(target.serial, target.baud, target.parity, target.stopbits,
                                 timeout)

    def located(self, view: HostView, error: Sequence[int]) -> ExecutionError:
        from mplang.csim import hostlink

        return hostlink.located(view, error)


host: HostSide = _HostSide()
"""`mpc call`, `mpc var`, `mpc export` and `mplang.host` for a CSIM (docs/host.md)."""
watch = None
"""No live view (`mpc monitor`): the dashboard polls Modbus registers, and a CSIM speaks its
RS232 ASCII command set (docs/monitor.md)."""

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
    "CsimProgram",
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
