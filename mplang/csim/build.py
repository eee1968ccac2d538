"""The CSIM build: programs (native `.csim` scripts or compiled from `.mp`), their
diagnostics and their renderings (listing, json, csim), as the family contract asks.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from mplang.csim import profile as profile_module
from mplang.csim.check import check_script
from mplang.csim.syntax import Script, parse_file
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span, suppressed

BUILD_FORMAT = "mplang-csim/1"
TARGETS: tuple[str, ...] = ("csim",)
SUFFIXES: tuple[str, ...] = (".csim",)
FORMATS = ("listing", "json", "csim")
TITLE = "CSIM"
DEFAULT_FORMAT = "csim"
"""What `mpc build` writes without --format: the script to download."""
POSITION_UNIT = "units"
"""The coordinate unit is set on the drive (PN44-46) and not defined by the manual."""
TRANSPORTS: tuple[str, ...] = ("serial",)
NO_TRANSPORT = ""
PROTOCOL = "rs232-ascii"
BUILD_OPTIONS: frozenset[str] = frozenset()
"""No build option beyond the common ones (no word order: the CSIM is not Modbus)."""
SERVE_OPTIONS: frozenset[str] = frozenset()
FLASH_OPTIONS: frozenset[str] = frozenset()
FLASHES_FLEETS = False
FLASH_INSTEAD = ""
"""`mpc sim` options beyond the common ones (the serial line, speed, duration)."""


@dataclass
class CsimProgram:
    """One CSIM program, as it would be downloaded: its lines, and where each came from."""

    name: str
    source: str
    script: Script
    origins: list[Span]
    entries: dict[str, str] = field(default_factory=dict)  # compiled: MP name -> label
    variables: dict[str, str] = field(default_factory=dict)  # compiled: VARn -> Rk
    compiled_from: list[str] = field(default_factory=list)
    names: dict[str, str] = field(default_factory=dict)  # compiled: declared name -> Rk
    declared_at: dict[str, str] = field(default_factory=dict)  # declared name -> file:line
    consts: list[tuple[str, int, str]] = field(default_factory=list)  # name, value, file:line

    @property
    def lines(self) -> list[str]:
        """The program lines exactly as they are sent (and listed back)."""
        return self.script.texts

    def to_json(self) -> dict[str, object]:
        return {
            "name": self.name, "source": self.source,
            "lines": [{"address": i, "text": text, "origin": str(origin)}
                      for i, (text, origin) in enumerate(zip(self.lines, self.origins,
                                                             strict=True))],
            "labels": {f"${name}": address for name, address in self.script.labels.items()},
            "entries": self.entries, "variables": self.variables,
            "compiled_from": self.compiled_from,
        }

    def csim_text(self) -> str:
        header = [f"# {self.name}: compiled by mpc from {', '.join(self.compiled_from)} "
                  "(target csim)"] if self.compiled_from else []
        if self.variables:
            header.append("# variables: " + ", ".join(f"{k}={v}"
                                                      for k, v in self.variables.items()))
        return "\n".join([*header, *self.lines]) + "\n"

    def listing(self) -> str:
        width = max((len(text) for text in self.lines), default=0)
        out = [f"program {self.name} ({self.source}): {len(self.lines)} lines"]
        for address, (text, origin) in enumerate(zip(self.lines, self.origins, strict=True)):
            out.append(f"  {address:04d}  {text.ljust(width)}  # {origin.file}:{origin.line}")
        return "\n".join(out)


@dataclass
class FamilyBuild:
    """What `check_native` and `compile_mp` return (the family contract)."""

    diagnostics: list[Diagnostic]
    programs: list[CsimProgram] = field(default_factory=list)
    target: str = "csim"

    @property
    def ok(self) -> bool:
        return not any(d.severity is Severity.ERROR for d in self.diagnostics)

    def to_json(self) -> dict[str, object]:
        return {
            "format": BUILD_FORMAT, "target": self.target, "ok": self.ok,
            "programs": [p.to_json() for p in self.programs],
            "diagnostics": [{"code": d.code, "severity": d.severity.value, "message": d.message,
                             "file": d.span.file, "line": d.span.line, "col": d.span.col}
                            for d in self.diagnostics],
        }

    def render(self, fmt: str) -> str:
        """`listing` (address, line, origin), `json`, or `csim` (the script to download)."""
        if fmt == "json":
            return json.dumps(self.to_json(), indent=1, ensure_ascii=False) + "\n"
        if fmt == "listing":
            return "\n\n".join(p.listing() for p in self.programs) + "\n"
        if fmt == "csim":
            if len(self.programs) == 1:
                return self.programs[0].csim_text()
            return "\n".join(f"# ---- program {p.name} ({p.source})\n{p.csim_text()}"
                             for p in self.programs)
        raise ValueError(f"unknown format {fmt!r}: choose one of {', '.join(FORMATS)}")


def check_native(paths: list[Path], target: str | None = None) -> FamilyBuild:
    """Parse and check `.csim` scripts, one program per file. Bad input of any kind becomes
    diagnostics; only an unknown `target` (a caller's mistake) raises ValueError."""
    if target is not None and target not in TARGETS:
        raise ValueError(f"unknown CSIM target {target!r}: choose one of {', '.join(TARGETS)}")
    profile = profile_module.load()
    sink = DiagnosticSink()
    programs: list[CsimProgram] = []
    sources: dict[str, list[str]] = {}
    for path in paths:
        display = str(path)
        if path.suffix.lower() not in SUFFIXES:
            sink.add("E701", Span(display, 1), f"{display} is not a CSIM script: CSIM sources "
                     f"end in {', '.join(SUFFIXES)}", hint="compile .mp sources with "
                     "--target csim instead")
            continue
        script = parse_file(path, sink, display)
        if script is None:
            continue
        sources[display] = script.file_lines
        check_script(script, profile, sink)
        programs.append(CsimProgram(script.name, display, script,
                                    [s.span for s in script.statements]))
    diagnostics = [d for d in sink.sorted() if not suppressed(d, sources)]
    return FamilyBuild(diagnostics, programs)
