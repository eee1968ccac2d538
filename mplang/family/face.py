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

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from mplang.family.trace import Trace
from mplang.ir.unit import Options
from mplang.lang.diagnostics import Diagnostic


class RunSetupError(ValueError):
    """The build does not load into the family's virtual controller."""


class NoSuchProgram(RunSetupError):
    """`--call` names a program that is not in the build."""


class ServiceError(Exception):
    """A virtual device cannot be served as asked. `kind`: "usage" (the request does not
    fit the family: the command line is wrong), "memory" (the memory file cannot be read or
    written), "refused" (the device refused the preloaded build), "transport" (the port or
    serial line cannot be opened or failed)."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


@dataclass(frozen=True)
class ServeRequest:
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
    def disassemble(self) -> Callable[[Any], Any] | None:
        """`mpc disasm` of the family's images, or None where it has none."""
        ...

    def check_native(self, paths: list[Path], target: str | None = None) -> FamilyBuild: ...

    def compile_mp(self, paths: list[Path], options: Options, target: str) -> FamilyBuild: ...

    def run_build(self, build: Any, call: str | None, max_time: float, *,
                  sample_period: float | None = ...) -> FamilyRun: ...
