"""A fourth controller family that exists only for the tests: a listing format `.toy` (one
`MOVE n` per line), checked natively, and `.mp` compiled through the shared IR. It proves
that a family is one package plus one registry line: nothing in `mpc` names it."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mplang.family.face import NoSuchProgram, RunSetupError
from mplang.family.run_error import RunError
from mplang.family.trace import SampledRun
from mplang.family.watch import Watch
from mplang.ir.unit import Options
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Span

TITLE = "Toy stepper"
TARGETS = ("toy",)
SUFFIXES = (".toy",)
FORMATS = ("toy", "json")
DEFAULT_FORMAT = "toy"
POSITION_UNIT = "steps"
TRANSPORTS: tuple[str, ...] = ()
NO_TRANSPORT = "a toy has no wire"
PROTOCOL = ""
BUILD_OPTIONS: frozenset[str] = frozenset()
SERVE_OPTIONS: frozenset[str] = frozenset()
FLASH_OPTIONS: frozenset[str] = frozenset()
FLASHES_FLEETS = False
FLASH_INSTEAD = "Copy the listing by hand"
serve = None
flash_devices = None
status_device = None
disassemble = None
debug = None
NO_DEBUG = "a toy runs its moves at once"
host = None
NO_HOST = "a toy has no registers"
watch = None
load_machine = None
NO_MACHINE = "a toy has no switches"

__all__ = ["NoSuchProgram", "RunSetupError"]


@dataclass
class ToyBuild:
    diagnostics: list[Diagnostic]
    moves: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.diagnostics

    @property
    def programs(self) -> Sequence[object]:
        return [self.moves]

    def render(self, fmt: str) -> str:
        if fmt == "json":
            return json.dumps(self.to_json()) + "\n"
        return "".join(f"MOVE {m}\n" for m in self.moves)

    def to_json(self) -> Mapping[str, object]:
        return {"format": "toy/1", "target": "toy", "moves": self.moves}


def check_native(paths: list[Path], target: str | None = None) -> ToyBuild:
    sink = DiagnosticSink()
    moves: list[int] = []
    for path in paths:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            word, _, value = line.partition(" ")
            if word != "MOVE" or not value.lstrip("-").isdigit():
                sink.add("E201", Span(str(path), number), f"not a toy line: {line!r}")
                continue
            moves.append(int(value))
    return ToyBuild(sink.sorted(), moves)


def compile_mp(paths: list[Path], options: Options, target: str, *,
               texts: dict[Path, str] | None = None) -> ToyBuild:
    raise RunSetupError("the toy compiles no .mp")


@dataclass
class ToyRun(SampledRun):
    called: str
    finished: bool
    error: str | None
    time_s: float
    samples: list[tuple[float, dict[str, float]]]
    sample_period: float | None

    POSITION_UNIT = POSITION_UNIT

    @property
    def failure(self) -> RunError | None:
        """The family face's run-time finding: the toy knows no place for its errors."""
        return None if self.error is None else RunError("R401", self.error)

    def to_json(self) -> Mapping[str, object]:
        end = self.samples[-1][1]["X"]
        return {"called": self.called, "vars": {}, "names": {},
                "axes": {"X": {"lp": end, "ep": end}}, "time_ms": self.time_s * 1000,
                "error": self.failure.to_json() if self.failure is not None else None}


def run_build(build: ToyBuild, call: str | None, max_time: float, *,
              sample_period: float | None = None, machine: object | None = None,
              watch: Watch | None = None) -> ToyRun:
    if call not in (None, "main"):
        raise NoSuchProgram(f"no program {call!r}; callable: main")
    position, samples = 0.0, [(0.0, {"X": 0.0})]
    for step, move in enumerate(build.moves, 1):
        position += move
        samples.append((step * 0.001, {"X": position}))
    return ToyRun("main", True, None, len(build.moves) * 0.001, samples, sample_period)
