"""FATEK FBs-PLC NC positioning programs (FUN140 HSPSO, FUN141 MPARA, FUN147 MHSPO).

The package satisfies the family face (`mplang.family.face.Family`): `check_native` (native
`.fbs` listings), `compile_mp` (`.mp` sources), `run_build` on a virtual PLC; no transport
(`NO_TRANSPORT` says why), so no `serve` either. docs/fatek.md describes the format, the
targets and the choices.
"""

from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.fatek.build import (
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
    FamilyBuild,
    check_native,
)
from mplang.fatek.compile import compile_mp
from mplang.fatek.run import FamilyRun, NoSuchTable, run_build

serve = None
"""No device service: nothing can reach a FATEK positioning table (`NO_TRANSPORT`)."""
flash_devices = None
"""Nothing to flash into (`NO_TRANSPORT`; `FLASH_INSTEAD` says what to do)."""
status_device = None  # no status reads: see docs/cli.md (mpc status)
disassemble = None
"""No image to read back: the listing is the program."""
load_machine = None
NO_MACHINE = ("a FATEK table describes its machine in the listing itself: SIM lines drive the "
              "DOG, limit and PG0 inputs and timed contacts (docs/fatek.md)")
"""No `--machine`: why not, for the command line's refusal."""
debug = None
"""No `mpc dap`: the virtual FBs-PLC runs a positioning table a step at a time with no place
to stop between steps (`NO_DEBUG`)."""
NO_DEBUG = ("the virtual FATEK PLC runs whole positioning-table steps and cannot stop at a "
            "source line; debug the same .mp sources with target et (the virtual M8194H)")
host = None
NO_HOST = ("a host cannot reach a FATEK positioning table by name: FB documents no way to "
           "download the table or read its state from a host (tables are entered with "
           "WinProladder's table editor, FB 809-839, 861), so there is no program to call and "
           "no declared variable to read on the PLC")
"""No `mpc call`, `mpc var`, `mpc export` or `mplang.host` (`NO_HOST` says why)."""
watch = None
"""No live view (`mpc monitor`): nothing can reach a FATEK positioning table
(`NO_TRANSPORT`)."""

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
    "NoSuchTable",
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
