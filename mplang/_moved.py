"""Import paths of the library API from before the package layout of docs/architecture.md:
`import mplang.compiler` and the like still find the module that now holds those names, so
scripts written against the earlier layout keep working. One finder, no copies of modules."""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.abc import Loader as _LoaderBase
else:
    _LoaderBase = object

MOVED = {
    "mplang.compiler": "mplang.m8194h.compiler",
    "mplang.link": "mplang.m8194h.link",
    "mplang.encode": "mplang.m8194h.encode",
    "mplang.disasm": "mplang.m8194h.disasm",
    "mplang.importc": "mplang.m8194h.importc",
    "mplang.flash": "mplang.m8194h.flash",
    "mplang.modbus": "mplang.m8194h.modbus",
    "mplang.run": "mplang.m8194h.run",
    "mplang.trace": "mplang.m8194h.trace",
    "mplang.sim": "mplang.m8194h.sim",
    "mplang.sim.ptylink": "mplang.family.ptylink",
    "mplang.catalogue": "mplang.ir.catalogue",
    "mplang.lower": "mplang.ir.lower",
    "mplang.configure": "mplang.ir.configure",
    "mplang.mpwriter": "mplang.ir.mpwriter",
    "mplang.frontend": "mplang.lang",
    "mplang.diagnostics": "mplang.lang.diagnostics",
    "mplang.rules": "mplang.lang.rules",
    "mplang.fmt": "mplang.tools.fmt",
    "mplang.plot": "mplang.tools.plot",
    "mplang.project": "mplang.tools.project",
    "mplang.lsp": "mplang.tools.lsp",
}
"""Old module -> the module that holds its names now; `mplang.sim.X` and the like follow
their package (`mplang.m8194h.sim.X`)."""


def new_name(old: str) -> str | None:
    """Where an old module name lives now, or None for a name that did not move."""
    if old in MOVED:
        return MOVED[old]
    package = old.rpartition(".")[0]
    while package:
        if package in MOVED:
            return f"{MOVED[package]}.{old[len(package) + 1:]}"
        package = package.rpartition(".")[0]
    return None


_IDENTITY = ("__name__", "__spec__", "__loader__", "__package__", "__file__", "__cached__")


class _Loader(_LoaderBase):
    """Hands out the module under its new name. The import system stamps the old name on
    whatever `create_module` returns; `exec_module` puts the module's own identity back.
    (The import protocols, not `importlib.abc`'s classes: importing those costs every `mpc`
    start, `--version` included, more than the rest of this package.)"""

    def __init__(self, target: str) -> None:
        self.target = target
        self.identity: dict[str, object] = {}

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(self.target)
        self.identity = {key: getattr(module, key) for key in _IDENTITY if hasattr(module, key)}
        return module

    def exec_module(self, module: ModuleType) -> None:
        for key, value in self.identity.items():
            setattr(module, key, value)


class MovedFinder:
    """Finds old names, and only those: every other import goes to the usual finders."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if not fullname.startswith("mplang."):
            return None
        moved = new_name(fullname)
        if moved is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _Loader(moved))


def install() -> None:
    if not any(isinstance(finder, MovedFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())  # before the path finder, which would
        # otherwise load a second copy of `mplang.sim.X` from the moved package's folder
