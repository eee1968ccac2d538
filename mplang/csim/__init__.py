"""The CSIM / SLIM RS232 command set (shared/manuals/004_fd07d4bf40d1e0ce.txt): native
`.csim` scripts, `.mp` compiled with `--target csim`, a virtual CSIM to run them on, and
program download over a serial line. The family contract of issue 7 (docs/csim.md), plus
what `mpc` needs: `TITLE`, `FORMATS` and `DEFAULT_FORMAT`, `POSITION_UNIT`, `TRANSPORTS`."""

from __future__ import annotations

from mplang.csim.build import (
    DEFAULT_FORMAT,
    FORMATS,
    NO_TRANSPORT,
    POSITION_UNIT,
    SUFFIXES,
    TARGETS,
    TITLE,
    TRANSPORTS,
    CsimProgram,
    FamilyBuild,
    check_native,
)
from mplang.csim.compile import compile_mp
from mplang.csim.run import FamilyRun, NoSuchProgram, RunSetupError, run_build

__all__ = ["DEFAULT_FORMAT", "FORMATS", "NO_TRANSPORT", "POSITION_UNIT", "SUFFIXES", "TARGETS",
           "TITLE", "TRANSPORTS", "CsimProgram", "FamilyBuild", "FamilyRun", "NoSuchProgram",
           "RunSetupError", "check_native", "compile_mp", "run_build"]
