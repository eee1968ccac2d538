"""The CSIM / SLIM RS232 command set (shared/manuals/004_fd07d4bf40d1e0ce.txt): native
`.csim` scripts, `.mp` compiled with `--target csim`, a virtual CSIM to run them on, and
program download over a serial line. The package satisfies the family face
(`mplang.family.face.Family`, docs/csim.md)."""

from __future__ import annotations

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

disassemble = None
"""No image format to read back: a CSIM lists its program itself (ULP)."""

__all__ = [
    "BUILD_OPTIONS",
    "DEFAULT_FORMAT",
    "FLASHES_FLEETS",
    "FLASH_INSTEAD",
    "FLASH_OPTIONS",
    "FORMATS",
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
    "disassemble",
    "flash_devices",
    "run_build",
    "serve",
    "status_device",
]
