"""FATEK FBs-PLC NC positioning programs (FUN140 HSPSO, FUN141 MPARA, FUN147 MHSPO).

The family API the CLI uses, the same for every controller family: `TARGETS`, `SUFFIXES`,
`check_native` (native `.fbs` listings), `compile_mp` (`.mp` sources), `FamilyBuild`,
`run_build` and `FamilyRun`. docs/fatek.md describes the format, the targets and the choices.
"""

from mplang.fatek.build import FORMATS, SUFFIXES, TARGETS, FamilyBuild, check_native
from mplang.fatek.compile import compile_mp
from mplang.fatek.run import FamilyRun, NoSuchTable, run_build

__all__ = ["FORMATS", "SUFFIXES", "TARGETS", "FamilyBuild", "FamilyRun", "NoSuchTable",
           "check_native", "compile_mp", "run_build"]
