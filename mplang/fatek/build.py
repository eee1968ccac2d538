"""The FATEK family's build: native listings in, checked tables (or diagnostics) out.

`check_native` is the `.fbs` front end of the family API; `mplang.fatek.compile.compile_mp`
makes the same `FamilyBuild` from `.mp` sources. Both never raise on bad input: every problem
is a diagnostic with its place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mplang.fatek import render
from mplang.fatek.check import Checker, settle_implicit
from mplang.fatek.model import PositioningTable, SimSetup, Table
from mplang.fatek.parser import parse_text
from mplang.fatek.profile import Profile, load
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span, suppressed

BUILD_FORMAT = "mplang-fatek/1"
TARGETS = ("fbs-fun140", "fbs-fun147")
SUFFIXES = (".fbs",)
FORMATS = ("fbs", "listing", "table", "json")
FUN_OF_TARGET = {"fbs-fun140": 140, "fbs-fun147": 147}
TITLE = "FATEK FBs-PLC"
DEFAULT_FORMAT = "fbs"
"""What `mpc build` writes without --format: the native listing, which reads back."""
POSITION_UNIT = "pulses"
"""Positions are reported in Ps, output pulses (FB 890-1019)."""
TRANSPORTS: tuple[str, ...] = ()
NO_TRANSPORT = ("FB documents no way to write positioning tables into a PLC: they are "
                "entered with WinProladder's table editor (FB 809-839, 861)")
"""Why `mpc flash` and `mpc sim` have nothing to offer for this family."""
PROTOCOL = ""
BUILD_OPTIONS: frozenset[str] = frozenset()
"""No build option beyond the common ones (no word order: no Modbus image)."""
SERVE_OPTIONS: frozenset[str] = frozenset()
FLASH_OPTIONS: frozenset[str] = frozenset()
FLASHES_FLEETS = False
FLASH_INSTEAD = ("Write the steps with `mpc build --target {target} --format fbs` and enter "
                 "them in WinProladder's table editor (--format table shows the register "
                 "layout only: FB documents no encoding of a step's words)")
"""What `mpc flash` suggests instead ({target}: the target asked for)."""


@dataclass
class FamilyBuild:
    """Checked FBs-PLC tables: FUN140/FUN147 positioning tables and FUN141 parameter tables
    (`programs`), the simulation set-up of the listings, and every diagnostic."""

    diagnostics: list[Diagnostic]
    programs: list[Table] = field(default_factory=list)
    sim: SimSetup = field(default_factory=SimSetup)
    target: str | None = None
    sources: dict[str, list[str]] = field(default_factory=dict)  # display name -> lines

    @property
    def ok(self) -> bool:
        return not any(d.severity is Severity.ERROR for d in self.diagnostics)

    @property
    def profile(self) -> Profile:
        return load()

    def positioning_tables(self) -> list[PositioningTable]:
        return [t for t in self.programs if isinstance(t, PositioningTable)]

    def render(self, fmt: str) -> str:
        """`fbs` (native listing, parses back), `listing` (steps with registers and source
        lines), `table` (register table layout) or `json`."""
        import json

        if fmt == "fbs":
            origin = ", ".join(self.sources) or "no sources"
            return render.render_fbs(self.programs, self.sim, f"FBs-PLC positioning tables "
                                     f"written by mplang from {origin}", self.profile)
        if fmt == "listing":
            return render.render_listing(self.programs, self.profile)
        if fmt == "table":
            return render.render_table(self.programs, self.profile)
        if fmt == "json":
            return json.dumps(self.to_json(), indent=1) + "\n"
        raise ValueError(f"unknown format {fmt!r}: use one of {', '.join(FORMATS)}")

    def to_json(self) -> dict[str, Any]:
        profile = self.profile
        return {
            "format": BUILD_FORMAT,
            "target": {"family": profile.raw["family"]["name"], "variant": self.target},
            "undefined_words": render.STEP_WORDS_NOTE,
            "tables": [render.table_json(t, profile) for t in self.programs],
        }


def display_name(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def check_target(target: str | None) -> None:
    if target is not None and target not in TARGETS:
        raise ValueError(f"unknown FATEK target {target!r}: use one of {', '.join(TARGETS)}")


def check_native(paths: list[Path], target: str | None = None, *,
                 texts: dict[Path, str] | None = None) -> FamilyBuild:
    """Parse and check FBs-PLC listings together (tables see each other: register overlaps,
    the FUN141 table a DRVZ needs). `target` settles the instruction of listings without a
    TABLE line; `texts` gives in-memory contents for some paths (tests, editors)."""
    check_target(target)
    profile = load()
    sink = DiagnosticSink()
    tables: list[Table] = []
    sim = SimSetup()
    sources: dict[str, list[str]] = {}
    for path in paths:
        display = display_name(path)
        text = _read(path, display, sink, texts)
        if text is None:
            continue
        parsed = parse_text(text, display, sink)
        sources[display] = parsed.lines
        tables.extend(parsed.tables)
        sim.merge(parsed.sim)
    settle_implicit(tables, FUN_OF_TARGET.get(target or ""))
    Checker(profile, sink).check(tables, sim)
    if target is not None:
        wanted = FUN_OF_TARGET[target]
        for table in tables:
            if isinstance(table, PositioningTable) and table.fun != wanted:
                sink.add("E616", table.span, f"{table.name!r} is a FUN{table.fun} table, but "
                         f"the target is {target}", hint="build it without --target, or with "
                         f"--target fbs-fun{table.fun}")
    diagnostics = [d for d in sink.sorted() if not suppressed(d, sources)]
    return FamilyBuild(diagnostics, tables, sim, target, sources)


def _read(path: Path, display: str, sink: DiagnosticSink,
          texts: dict[Path, str] | None) -> str | None:
    if texts is not None and path in texts:
        return texts[path]
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        sink.add("E105", Span(display, 1), f"{display} is not UTF-8 text ({exc.reason})")
    except OSError as exc:
        sink.add("E102", Span(display, 1), f"cannot read {display}: {exc.strerror or exc}")
    return None
