"""FATEK FBs-PLC NC positioning programs (FUN140 HSPSO, FUN141 MPARA, FUN147 MHSPO).

The family API the CLI uses, the same for every controller family: `TARGETS`, `SUFFIXES`,
`check_native` (native `.fbs` listings), `compile_mp` (`.mp` sources), `FamilyBuild`,
`run_build` and `FamilyRun`; for `mpc` also `TITLE`, `FORMATS` and `DEFAULT_FORMAT`,
`POSITION_UNIT`, `TRANSPORTS` (none: `NO_TRANSPORT` says why), and the errors of
`run_build`, `NoSuchProgram` and `RunSetupError`. docs/fatek.md describes the format, the
targets and the choices.
"""

from mplang.fatek.build import (
    DEFAULT_FORMAT,
    FORMATS,
    NO_TRANSPORT,
    POSITION_UNIT,
    SUFFIXES,
    TARGETS,
    TITLE,
    TRANSPORTS,
    FamilyBuild,
    check_native,
)
from mplang.fatek.compile import compile_mp
from mplang.fatek.run import FamilyRun, NoSuchTable, run_build
from mplang.m8194h.run import NoSuchProgram, RunSetupError

__all__ = ["DEFAULT_FORMAT", "FORMATS", "NO_TRANSPORT", "POSITION_UNIT", "SUFFIXES", "TARGETS",
           "TITLE", "TRANSPORTS", "FamilyBuild", "FamilyRun", "NoSuchProgram", "NoSuchTable",
           "RunSetupError", "check_native", "compile_mp", "run_build"]
