"""The M8194H download image: what a build produces (`BuildResult`: programs placed in
slots, their frames, the INIT table, the TRIGGERS table) and its renderings: image JSON,
human listing, hex dump, link map, trigger table and variable maps.

`BuildResult` satisfies the family face (`mplang.family.face.FamilyBuild`): `render(fmt)`
gives any of `FORMATS`, `to_json()` the image."""

from __future__ import annotations

import json
from collections.abc import Callable
from json import dumps
from json.encoder import encode_basestring_ascii
from typing import Any

from mplang.ir import catalogue as catalogue_module
from mplang.ir.lower import Variable
from mplang.ir.macro import LoweredProgram, MacroLine
from mplang.lang.diagnostics import Diagnostic, Severity, Span
from mplang.lang.digest import sha256
from mplang.lang.record import Record
from mplang.m8194h.link import Placement

IMAGE_FORMAT = "mplang-image/1"
FORMATS = ("json", "listing", "hex", "map", "vars", "vars-h", "vars-py", "triggers")
"""`mpc build --format` values of an M8194H build (the image and its views)."""
DEFAULT_FORMAT = "json"


class LineFrames(Record):
    """One macro line as downloaded: where it came from and where it sits in the slot."""

    line: MacroLine
    first_slot_line: int  # 0-based, as the device's wLineNo counts
    frame: list[int]
    _fields = __match_args__ = ("line", "first_slot_line", "frame")

    def __init__(self, line: MacroLine, first_slot_line: int, frame: list[int]) -> None:
        self.line = line
        self.first_slot_line = first_slot_line
        self.frame = frame


class ProgramImage(Record):
    placement: Placement
    create: list[int]
    lines: list[LineFrames]
    close: list[int]
    close_span: Span
    _fields = __match_args__ = ("placement", "create", "lines", "close", "close_span")

    def __init__(self, placement: Placement, create: list[int], lines: list[LineFrames],
                 close: list[int], close_span: Span) -> None:
        self.placement = placement
        self.create = create
        self.lines = lines
        self.close = close
        self.close_span = close_span

    @property
    def program(self) -> LoweredProgram:
        return self.placement.program

    @property
    def frames(self) -> list[list[int]]:
        return [self.create, *(lf.frame for lf in self.lines), self.close]

    @property
    def frame_lines(self) -> list[int]:
        """The source line of each frame in `source` (create: the MP/ISR line, close: its END
        line), so a device's refusal can be traced back to the source from the image alone."""
        return [self.program.span.line, *(lf.line.span.line for lf in self.lines),
                self.close_span.line]

    def to_json(self) -> dict[str, object]:
        program = self.program
        return {
            "kind": program.kind, "slot": self.placement.slot, "name": program.name,
            "source": program.source, "lines_used": self.placement.lines_used,
            "budget": self.placement.budget, "auto_placed": self.placement.auto,
            "frame_lines": self.frame_lines, "frames": self.frames,
        }


class InitImage(Record):
    """The INIT block as downloaded: real-time frames (INITIAL_* axis codes), LOAD_INITIAL
    last. Not a macro program: no slot, no budget."""

    program: LoweredProgram
    frames: list[list[int]]
    _fields = __match_args__ = ("program", "frames")

    def __init__(self, program: LoweredProgram, frames: list[list[int]]) -> None:
        self.program = program
        self.frames = frames

    def to_json(self) -> dict[str, object]:
        return {"source": self.program.source, "line": self.program.span.line,
                "frame_lines": [line.span.line for line in self.program.lines],
                "frames": self.frames}


class TriggerImage(Record):
    """The stand-alone trigger table with program slots resolved (chapter 10)."""

    source: str
    line: int
    entries: list[dict[str, object]]
    enabled: bool
    _fields = __match_args__ = ("source", "line", "entries", "enabled")

    def __init__(self, source: str, line: int, entries: list[dict[str, object]],
                 enabled: bool = True) -> None:
        self.source = source
        self.line = line
        self.entries = entries
        self.enabled = enabled

    def to_json(self) -> dict[str, object]:
        return {"enabled": self.enabled, "source": self.source, "line": self.line,
                "entries": self.entries}


class BuildResult(Record):
    diagnostics: list[Diagnostic]
    programs: list[ProgramImage]
    word_order: int
    target: str
    sources: dict[str, list[str]]  # display name -> lines
    variables: list[Variable]  # `VAR name` declarations
    aliases: list[Variable]  # `ALIAS name = VARn`, for run results
    init: InitImage | None  # the INIT block
    triggers: TriggerImage | None  # the TRIGGERS table
    first_source: str | None  # display name of the first file given (`mpc run`'s default)
    _fields = __match_args__ = ("diagnostics", "programs", "word_order", "target", "sources",
                                "variables", "aliases", "init", "triggers", "first_source")

    def __init__(self, diagnostics: list[Diagnostic],
                 programs: list[ProgramImage] | None = None, word_order: int = 0,
                 target: str = "et", sources: dict[str, list[str]] | None = None,
                 variables: list[Variable] | None = None,
                 aliases: list[Variable] | None = None, init: InitImage | None = None,
                 triggers: TriggerImage | None = None,
                 first_source: str | None = None) -> None:
        self.diagnostics = diagnostics
        self.programs = [] if programs is None else programs
        self.word_order = word_order
        self.target = target
        self.sources = {} if sources is None else sources
        self.variables = [] if variables is None else variables
        self.aliases = [] if aliases is None else aliases
        self.init = init
        self.triggers = triggers
        self.first_source = first_source

    @property
    def ok(self) -> bool:
        error = Severity.ERROR  # compared by identity: thousands of warnings are looked at
        return not any(d.severity is error for d in self.diagnostics)

    def build_id(self, frames: list[str] | None = None) -> str:
        """Content hash of what would be downloaded: the same image, the same id. It hashes
        `json.dumps([word_order, [each program's frames], {"init": ...}, {"triggers": ...}])`,
        put together from `frames` (each program's frames as `json.dumps` gives them) when
        given: `render_json` encodes a whole device's frames once for both."""
        if frames is None:
            frames = [dumps(p.frames) for p in self.programs]
        text = f"[{dumps(self.word_order)}, [{', '.join(frames)}]"
        if self.init is not None:
            text += ", " + dumps({"init": self.init.frames})
        if self.triggers is not None:
            text += ", " + dumps({"triggers": self.triggers.to_json()["entries"]})
        return sha256((text + "]").encode()).hexdigest()[:16]

    def to_json(self) -> dict[str, object]:
        """The image (the family face's name for it)."""
        return self.image()

    def render(self, fmt: str) -> str:
        """The build in one of `FORMATS`."""
        renderers: dict[str, Callable[[BuildResult], str]] = {
            "json": render_json,
            "listing": lambda result: render_listing(result, result.sources),
            "hex": render_hex, "map": render_link_map, "vars": render_variables_json,
            "vars-h": render_variables_c, "vars-py": render_variables_python,
            "triggers": render_triggers,
        }
        return renderers[fmt](self)

    def image(self, programs: list[dict[str, object]] | None = None,
              frames: list[str] | None = None) -> dict[str, object]:
        """The image as JSON values; `programs` (each program's `to_json()`) and `frames`
        (as `build_id` takes them) when the caller made them already."""
        image: dict[str, object] = {
            "format": IMAGE_FORMAT,
            "target": {"word_order": self.word_order, "family": "M8194H",
                       "variant": self.target},
            "build_id": self.build_id(frames),
        }
        if self.init is not None:
            image["init"] = self.init.to_json()
        if self.triggers is not None:
            image["triggers"] = self.triggers.to_json()
        image["programs"] = [p.to_json() for p in self.programs] if programs is None else programs
        return image


VARIABLES_FORMAT = "mplang-variables/1"


def _hex(frame: list[int]) -> str:
    return " ".join(f"{word:04X}" for word in frame)


def _slot_lines(first: int, cost: int) -> str:
    return str(first) if cost == 1 else f"{first}-{first + cost - 1}"


def _scalar(value: object) -> str:
    """`json.dumps(value)` of a member of a frames object, without its call for the common
    kinds: json.dumps makes an encoder for every number and None, and an image of a whole
    device has a thousand such members."""
    if value is None:
        return "null"
    if value is True:
        return "true"
    if value is False:
        return "false"
    if type(value) is str:
        return encode_basestring_ascii(value)
    if type(value) is int:
        return int.__repr__(value)
    return dumps(value)


def _frames_object(obj: dict[str, Any], indent: str, frames: str) -> str:
    """A JSON object at `indent` whose frame_lines sit on one line and whose frames
    (`frames`: the object's frames as `json.dumps` gives them, made once by the caller) are
    one per line (the object's first line carries no indent: the caller places it).

    Written through json's C encoder: every scalar and all frames at once (a frame is a list
    of numbers, so `], [` is only ever between two of them), byte for byte what the
    indented pure-Python encoder gives; a member that is not a scalar goes through it."""
    del obj["frames"]
    lines = obj.pop("frame_lines")
    if all(value is None or isinstance(value, (str, int, float)) for value in obj.values()):
        body = "{\n" + ",\n".join(f"{indent}  {encode_basestring_ascii(key)}: {_scalar(value)}"
                                   for key, value in obj.items())
    else:
        body = json.dumps(obj, indent=2).replace("\n", "\n" + indent)[:-(len(indent) + 2)]
    frame_text = f"{indent}    " + frames[1:-1].replace("], [", f"],\n{indent}    [") \
        if frames != "[]" else ""
    return (f"{body},\n{indent}  \"frame_lines\": {dumps(lines)},\n"
            f"{indent}  \"frames\": [\n{frame_text}\n{indent}  ]\n{indent}}}")


def render_json(result: BuildResult) -> str:
    """Indented JSON with each frame kept on one line, so images diff well. Each program's
    frames are encoded once, for the build id and for the text."""
    programs = [program.to_json() for program in result.programs]
    frames = [dumps(program["frames"]) for program in programs]
    image = result.image(programs, frames)
    del image["programs"]
    init = image.pop("init", None)
    triggers = image.pop("triggers", None)
    head = json.dumps(image, indent=2)[:-2]
    if isinstance(init, dict):
        head += ',\n  "init": ' + _frames_object(init, "  ", dumps(init["frames"]))
    if triggers is not None:
        head += ',\n  "triggers": ' + json.dumps(triggers, indent=2).replace("\n", "\n  ")
    parts = [f"    {_frames_object(program, '    ', text)}"
             for program, text in zip(programs, frames, strict=True)]
    return head + ',\n  "programs": [\n' + ",\n".join(parts) + "\n  ]\n}\n"


def render_listing(result: BuildResult, sources: dict[str, list[str]]) -> str:
    """Per source line: slot line numbers it occupies, their cost, and the frames in hex.
    The source column is as wide as the longest `file:line` (at least 24), so the columns
    hold for long paths."""
    w = _source_width(result)
    out = [f"; mplang listing  build {result.build_id()}  target {result.target.upper()}-M8194H"
           f"  word order {result.word_order}"]
    if result.init is not None:
        init = result.init.program
        out.append("")
        out.append(f"INIT  ({init.span.file}:{init.span.line}, initial table: real-time "
                   "commands, LOAD_INITIAL last)")
        out.append(f"  {'source':<{w}} {'':>7} {'':>4}  frame")
        for line, frame in zip(init.lines, result.init.frames, strict=True):
            source_lines = sources.get(line.span.file, [])
            text = source_lines[line.span.line - 1].strip() \
                if 0 < line.span.line <= len(source_lines) else ""
            out.append(f"  {line.span.file + ':' + str(line.span.line):<{w}} {'':>7} {'':>4}  "
                       f"{_hex(frame):<44}  {text}".rstrip())
    if result.triggers is not None:
        out.append("")
        out.append(render_triggers(result).rstrip("\n"))
    for image in result.programs:
        program, placement = image.program, image.placement
        title = f"{program.kind.upper()}{placement.slot}" + (f" {program.name}" if program.name
                                                              else "")
        placed = "auto-placed" if placement.auto else "pinned"
        out.append("")
        out.append(f"{title}  ({program.span.file}:{program.span.line}, {placed})  "
                   f"{placement.lines_used}/{placement.budget} lines")
        out.append(f"  {'source':<{w}} {'lines':>7} {'cost':>4}  frame")
        out.append(f"  {'(create)':<{w}} {'':>7} {'':>4}  {_hex(image.create)}")
        previous: tuple[str, int] | None = None
        for lf in image.lines:
            span = lf.line.span
            where = f"{span.file}:{span.line}"
            key = (span.file, span.line)
            text = ""
            if key != previous:
                lines = sources.get(span.file, [])
                text = lines[span.line - 1].strip() if 0 < span.line <= len(lines) else ""
            out.append(f"  {where if key != previous else '':<{w}} "
                       f"{_slot_lines(lf.first_slot_line, lf.line.command.line_cost):>7} "
                       f"{lf.line.command.line_cost:>4}  {_hex(lf.frame):<44}"
                       f"{'  ' + text if text else ''}".rstrip())
            previous = key
        used = placement.lines_used
        close_where = f"{image.close_span.file}:{image.close_span.line}"
        close_line = str(used - 1) if result_close_counts(image) else "-"
        out.append(f"  {close_where:<{w}} {close_line:>7} {'1' if close_line != '-' else '0':>4}  "
                   f"{_hex(image.close):<44}  END {program.kind.upper()}")
    return "\n".join(out) + "\n"


def _source_width(result: BuildResult) -> int:
    """The listing's source column: the longest `file:line` it shows, at least 24."""
    spans = [lf.line.span for image in result.programs for lf in image.lines]
    spans += [image.close_span for image in result.programs]
    if result.init is not None:
        spans += [line.span for line in result.init.program.lines]
    return max([24, *(len(f"{span.file}:{span.line}") for span in spans)])


def result_close_counts(image: Any) -> bool:
    lines = sum(lf.line.command.line_cost for lf in image.lines)
    return bool(image.placement.lines_used > lines)


def render_hex(result: BuildResult) -> str:
    """One frame per line: `<slot> <index>: <registers>`, for diffing and for other tools."""
    out = [f"# mplang hex  build {result.build_id()}  word order {result.word_order}"]
    if result.init is not None:
        for index, frame in enumerate(result.init.frames):
            out.append(f"{'INIT':<6} {index:>3}: {_hex(frame)}")
    for image in result.programs:
        label = f"{image.program.kind.upper()}{image.placement.slot}"
        for index, frame in enumerate(image.frames):
            out.append(f"{label:<6} {index:>3}: {_hex(frame)}")
    return "\n".join(out) + "\n"


def render_link_map(result: BuildResult) -> str:
    out = [f"{'slot':<7} {'name':<20} {'lines':>9}  {'placed':<7} source"]
    total_used = total_budget = 0
    for image in result.programs:
        p = image.placement
        out.append(f"{image.program.kind.upper() + str(p.slot):<7} "
                   f"{image.program.name or '-':<20} {p.lines_used:>4}/{p.budget:<4}  "
                   f"{'auto' if p.auto else 'pinned':<7} "
                   f"{image.program.span.file}:{image.program.span.line}")
        total_used += p.lines_used
        total_budget += p.budget
    out.append(f"{len(result.programs)} programs, {total_used} of {total_budget} lines in their "
               f"slots used")
    return "\n".join(out) + "\n"


def render_triggers(result: BuildResult) -> str:
    """The TRIGGERS table as the vendor utility's "FRnet DI Setting" window shows it
    (chapter 10): what to enter there, since no register layout of the table is documented."""
    profile = catalogue_module.load().profile.raw["trigger_table"]
    table = result.triggers
    if table is None:
        return "; no TRIGGERS block in this build\n"
    out = [f"TRIGGERS  ({table.source}:{table.line}; enter in EzMove: Setting -> FRnet DI..., "
           "then Send Table; mpc flash enables it through holding register "
           f"{profile['enable_register']})",
           f"  {'Group':<6} {'Channel':<8} {'Trigger Condition':<18} {'Event Type':<20} "
           f"{'Axis':<5} line"]
    names = {v.upper().replace(" ", "_"): v for v in profile["conditions"].values()}
    axis_name = catalogue_module.load().profile.axis_name
    for entry in table.entries:
        condition = names.get(str(entry["condition"]).upper().replace("-", "_"),
                              str(entry["condition"]))
        event = str(profile["events"][entry["event"]])
        if entry["event"] == "mp":
            event = f"MP{entry['mp']}"
        axes = axis_name(int(str(entry["axes"]))) if entry["event"] == "hold-drive" else ""
        out.append(f"  {entry['group']:<6} {entry['channel']:<8} {condition:<18} {event:<20} "
                   f"{axes:<5} {entry['line']}".rstrip())
    out.append("  every other channel: None")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------ variable maps
def _holding_base() -> int:
    """VARn lives at holding register base + 2n (device.toml [variables] holding_base)."""
    return int(catalogue_module.load().profile.var("holding_base"))


def _variable_rows(result: BuildResult) -> list[dict[str, Any]]:
    base = _holding_base()
    return [{"name": v.name, "var": v.index, "register": base + 2 * v.index,
             "pinned": v.pinned, "source": f"{v.span.file}:{v.span.line}"}
            for v in result.variables]


def render_variables_json(result: BuildResult) -> str:
    """`--format vars`: the declared variables, for host programs and HMIs."""
    return json.dumps({"format": VARIABLES_FORMAT, "build_id": result.build_id(),
                       "word_order": result.word_order, "holding_base": _holding_base(),
                       "variables": _variable_rows(result)}, indent=2) + "\n"


def render_variables_c(result: BuildResult) -> str:
    """`--format vars-h`: a C header, for host programs written against the vendor DLL."""
    out = [f"/* Variable map of mplang build {result.build_id()}: written by mpc build "
           "--format vars-h. Do not edit. */",
           "#ifndef MPC_VARIABLES_H", "#define MPC_VARIABLES_H", "",
           "/* VARn is the signed 32-bit value in holding registers MPC_REG_x and MPC_REG_x + 1;",
           "   MPC_WORD_ORDER 0: the first of them holds the high word, 1: the low word. */",
           f"#define MPC_WORD_ORDER {result.word_order}",
           f"#define MPC_HOLDING_BASE {_holding_base()}", ""]
    for row in _variable_rows(result):
        name = row["name"].upper()
        out.append(f"#define MPC_VAR_{name} {row['var']}  /* {row['source']}"
                   f"{', pinned' if row['pinned'] else ''} */")
        out.append(f"#define MPC_REG_{name} {row['register']}")
    out += ["", "#endif /* MPC_VARIABLES_H */"]
    return "\n".join(out) + "\n"


def render_variables_python(result: BuildResult) -> str:
    """`--format vars-py`: a Python module with the map and the 32-bit word split."""
    rows = _variable_rows(result)
    names = ",\n".join(f"    {row['name']!r}: {row['var']}" for row in rows)
    constants = "\n".join(f"{row['name'].upper()} = {row['var']}  # {row['source']}"
                          for row in rows)
    return f'''"""Variable map of mplang build {result.build_id()}: written by `mpc build --format
vars-py`. Do not edit. VARn is a signed 32-bit value in holding registers HOLDING_BASE + 2n
and the next one, in the device's word order (holding register 14)."""

WORD_ORDER = {result.word_order}
HOLDING_BASE = {_holding_base()}
VARIABLES = {{
{names}{"," if rows else ""}
}}

{constants}


def register(name: str) -> int:
    """The first holding register of a variable, by name."""
    return HOLDING_BASE + 2 * VARIABLES[name]


def to_registers(value: int) -> list[int]:
    """A signed 32-bit value as the two registers to write (FC16), in the word order."""
    if not -2**31 <= value < 2**31:
        raise ValueError(f"{{value}} does not fit a 32-bit variable")
    raw = value & 0xFFFFFFFF
    high, low = raw >> 16, raw & 0xFFFF
    return [high, low] if WORD_ORDER == 0 else [low, high]


def from_registers(words: list[int]) -> int:
    """The signed 32-bit value of the two registers read (FC3) from `register(name)`."""
    high, low = (words[0], words[1]) if WORD_ORDER == 0 else (words[1], words[0])
    raw = (high << 16) | low
    return raw - 2**32 if raw >= 2**31 else raw
'''
