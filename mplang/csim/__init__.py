"""The CSIM / SLIM RS232 command set (shared/manuals/004_fd07d4bf40d1e0ce.txt): native
`.csim` scripts, `.mp` compiled with `--target csim`, a virtual CSIM to run them on, and
program download over a serial line. The family contract of issue 7 (docs/csim.md)."""

from __future__ import annotations

from mplang.csim.build import SUFFIXES, TARGETS, CsimProgram, FamilyBuild, check_native
from mplang.csim.compile import compile_mp
from mplang.csim.run import FamilyRun, NoSuchProgram, RunSetupError, run_build

__all__ = ["SUFFIXES", "TARGETS", "CsimProgram", "FamilyBuild", "FamilyRun", "NoSuchProgram",
           "RunSetupError", "check_native", "compile_mp", "run_build"]
