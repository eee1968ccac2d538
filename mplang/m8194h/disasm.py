"""`mpc disasm`: an image back to readable `.mp` source that rebuilds to the same frames.

Every frame is decoded with the catalogue (`Encoder.decode`, the decoder the virtual
controller uses too). Lines become statements through `mplang.ir.mpwriter`: block commands as
FOR/NEXT, IF/ELSE/END IF, LABEL/GOTO, CALL, EXIT; SET_VAR and VAR_CALCULATE as assignments; a
read followed by SET_RVAR as `VARn = GET_LP(X)`. Lines the compiler computed through its
temporaries (the pool given by `temps`, VAR500-VAR511 by default) are folded back into one
expression, and, where the image says they came from the same source line, so are the steps
the compiler computed in the target variable itself.

Nothing is trusted blindly: each program is rebuilt from its text and compared frame for frame
with the image. A program whose lifted text does not rebuild exactly is written one statement
per line instead; a line that cannot be written as source at all (an unknown sub-function
code, a real-time command, an operand the compiler refuses) becomes a comment and is reported
in `Disassembly.problems`, so that nothing is lost silently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue, Command
from mplang.ir.macro import Operand, VarRef
from mplang.ir.mpwriter import (
    IDENTIFIER,
    Bin,
    Expr,
    Query,
    Writer,
    block_role,
    is_complex,
    is_value,
    render_expr,
    variables_in,
)
from mplang.ir.scope import Scope
from mplang.lang.diagnostics import Severity
from mplang.lang.limits import read_json_file
from mplang.m8194h.compiler import DEFAULT_TEMPS, BuildResult, Options, compile_source
from mplang.m8194h.encode import EncodeError, Encoder
from mplang.m8194h.flash import FlashImage, FlashProgram, load_image

CHECK_NAME = "<disasm>.mp"


@dataclass
class Item:
    """One stored line of a program: frame index, decoded command (None: undecodable)."""

    index: int
    frame: list[int]
    line: int | None
    command: Command | None = None
    operands: tuple[Operand, ...] = ()
    error: str | None = None


@dataclass
class Statement:
    """One output line of a program body and the frames (item indices) it stands for."""

    text: str
    items: list[int]
    line: int | None
    role: str = ""
    target: VarRef | None = None  # an assignment's variable, for merging steps into it
    expr: Expr | None = None
    comment: str | None = None  # why the line is only a comment


@dataclass
class ProgramText:
    program: FlashProgram
    name: str | None
    body: list[Statement]
    excluded: dict[int, str] = field(default_factory=dict)  # item index -> reason


@dataclass
class Disassembly:
    """The source text and what could not be carried over exactly (empty: exact)."""

    text: str
    problems: list[str]

    @property
    def exact(self) -> bool:
        return not self.problems


# ------------------------------------------------------------------------------ entry points
def disassemble_file(path: Path, temps: range = DEFAULT_TEMPS,
                     catalogue: Catalogue | None = None) -> Disassembly:
    """Read and check an image JSON (`mplang.m8194h.flash.load_image`: OSError, ImageError) and
    disassemble it."""
    catalogue = catalogue or catalogue_module.load()
    image = load_image(path, catalogue)
    variant = _variant(path)
    return disassemble(image, temps, catalogue, origin=str(path), variant=variant)


def _variant(path: Path) -> str | None:
    try:
        data = read_json_file(path)
        target = data.get("target", {})
        value = target.get("variant") if isinstance(target, dict) else None
        return value if value in ("et", "rs") else None
    except (OSError, ValueError, AttributeError):
        return None


def disassemble(image: FlashImage, temps: range = DEFAULT_TEMPS,
                catalogue: Catalogue | None = None, origin: str = "image",
                variant: str | None = None) -> Disassembly:
    """`.mp` source for every program of `image`, verified by rebuilding it."""
    catalogue = catalogue or catalogue_module.load()
    encoder = Encoder(catalogue, image.word_order)
    names = _program_names(image.programs, catalogue)
    decoded = [(program, _decode(program, encoder)) for program in image.programs]
    target = variant or _guess_target(decoded)
    options = Options(word_order=image.word_order, target=target, temps=temps)
    problems: list[str] = []
    texts: list[ProgramText] = []
    for program, items in decoded:
        text = _disassemble_program(program, items, names, catalogue, options, image)
        texts.append(text)
        for index, reason in sorted(text.excluded.items()):
            words = " ".join(f"{w:04X}" for w in program.frames[index])
            problems.append(f"{program.label}: frame {index} ({words}) cannot be written as "
                            f".mp: {reason}")
    header = _file_header(image, origin, target, temps)
    config = _render_init(image, catalogue, encoder, problems) + _render_triggers(image,
                                                                                  catalogue)
    source = header + config + "\n".join(_render_program(t, temps) for t in texts)
    problems += _whole_build_problems(source, image, texts, options)
    return Disassembly(source, problems)


# ------------------------------------------------------------------ configuration blocks
def _render_init(image: FlashImage, catalogue: Catalogue, encoder: Encoder,
                 problems: list[str]) -> str:
    """The image's initial table as an INIT block: axes written plainly (inside INIT, X
    means INITIAL_X), LOAD_INITIAL left to END INIT."""
    if image.init is None:
        return ""
    offset = int(catalogue.profile.raw["axes"]["initial_table_offset"])
    lines = ["INIT"]
    for index, frame in enumerate(image.init.frames[:-1]):
        line = image.init.lines[index] if index < len(image.init.lines) else None
        comment = f"line {line}" if line is not None else ""
        words = " ".join(f"{w:04X}" for w in frame)
        try:
            command, operands = encoder.decode(frame)
        except EncodeError as exc:
            problems.append(f"INIT: frame {index} ({words}) cannot be written as .mp: {exc}")
            lines.append(_with_comment(f"    # {words}", f"not decodable: {exc}"))
            continue
        args = []
        for param, operand in zip(command.params, operands, strict=True):
            if param.kind == "axis_it" and isinstance(operand, int) and operand & offset:
                args.append(catalogue.profile.axis_name(operand - offset))
            else:
                args.append(str(operand))
        text = f"    {command.short_name}" + (f" {', '.join(args)}" if args else "")
        lines.append(_with_comment(text, comment))
    lines.append("END INIT")
    return "\n".join(lines) + "\n\n"


def _render_triggers(image: FlashImage, catalogue: Catalogue) -> str:
    if image.triggers is None:
        return ""
    lines = ["TRIGGERS"]
    for entry in image.triggers.entries:
        condition = str(entry.get("condition", "")).upper().replace("-", "_")
        event = entry.get("event")
        action = {"abort-command": "ABORT COMMAND", "abort-macro": "ABORT MACRO"}.get(
            str(event), "")
        if event == "mp":
            action = f"CALL MP {entry.get('mp')}"
        elif event == "hold-drive":
            action = f"HOLD {catalogue.profile.axis_name(int(str(entry.get('axes', 0))))}"
        text = f"    ON DI {entry.get('group')}.{entry.get('channel')} {condition} {action}"
        line = entry.get("line")
        lines.append(_with_comment(text, f"line {line}" if line is not None else ""))
    lines.append("END TRIGGERS")
    return "\n".join(lines) + "\n\n"


# ------------------------------------------------------------------------------ decoding
def _decode(program: FlashProgram, encoder: Encoder) -> list[Item]:
    items: list[Item] = []
    for index in range(1, len(program.frames) - 1):
        frame = program.frames[index]
        line = program.lines[index] if index < len(program.lines) else None
        item = Item(index, frame, line)
        try:
            item.command, item.operands = encoder.decode(frame)
        except EncodeError as exc:
            item.error = str(exc)
        items.append(item)
    return items


def _guess_target(decoded: list[tuple[FlashProgram, list[Item]]]) -> str:
    """Images without a variant: RS if a line only exists on the RS-M8194H (INTP_END)."""
    for _program, items in decoded:
        for item in items:
            if item.command is not None and "et" not in item.command.targets:
                return "rs"
    return "et"


def _program_names(programs: Sequence[FlashProgram], catalogue: Catalogue
                   ) -> dict[tuple[str, int], str]:
    """Names usable in source: identifiers that are not reserved, each once."""
    from mplang.lang.diagnostics import DiagnosticSink

    scope = Scope(catalogue, DiagnosticSink())
    names: dict[tuple[str, int], str] = {}
    seen: set[str] = set()
    for program in programs:
        name = program.name
        if name and IDENTIFIER.fullmatch(name) and scope.reserved(name) is None and \
                name.upper() not in seen:
            seen.add(name.upper())
            names[(program.kind, program.slot)] = name
    return names


# ------------------------------------------------------------------------------ lifting
def _label_names(items: Sequence[Item]) -> dict[int, str]:
    """`L0`.. when named labels keep their numbers (the compiler numbers named labels in
    order of definition), else none: numbers stay."""
    defined: list[int] = []
    for item in items:
        if item.command is not None and item.command.short_name == "LABEL" and \
                isinstance(item.operands[0], int):
            defined.append(item.operands[0])
    if defined != list(range(len(defined))):
        return {}
    return {n: f"L{n}" for n in defined}


class _Lifter:
    """Turns the items of one program into statements at one lifting level."""

    def __init__(self, items: Sequence[Item], writer: Writer, temps: range, level: str,
                 excluded: dict[int, str]) -> None:
        self.items = items
        self.writer = writer
        self.temps = temps
        self.level = level
        self.excluded = excluded
        self.out: list[Statement] = []
        self.pending: dict[int, tuple[Expr, list[int], int | None]] = {}
        self.lines_known = all(item.line is not None for item in items)

    # ------------------------------------------------------------------ helpers
    def emit(self, statement: Statement) -> None:
        self.out.append(statement)

    def flush(self) -> None:
        """Temporaries that no consumer took: written out as plain assignments."""
        for index, (expr, used, line) in sorted(self.pending.items(), key=lambda kv: kv[1][1]):
            self.emit(Statement(f"VAR{index} = {render_expr(expr)}", used, line,
                                target=VarRef(index), expr=expr))
        self.pending.clear()

    def take(self, operand: Operand, line: int | None) -> Expr | None:
        """The pending expression of a temporary read at `line`, if it may be inlined."""
        if not isinstance(operand, VarRef) or operand.index not in self.pending:
            return None
        expr, _used, at = self.pending[operand.index]
        if self.lines_known and at != line:
            return None
        return expr

    def is_temp(self, ref: Operand) -> bool:
        return isinstance(ref, VarRef) and ref.index in self.temps

    # ------------------------------------------------------------------ main loop
    def run(self) -> list[Statement]:
        index = 0
        while index < len(self.items):
            item = self.items[index]
            if item.index in self.excluded or item.command is None:
                self.flush()
                reason = self.excluded.get(item.index) or item.error or "undecodable"
                self.excluded[item.index] = reason
                words = " ".join(f"{w:04X}" for w in item.frame)
                self.emit(Statement(f"# frame {item.index}: {words}", [item.index], item.line,
                                    comment=reason))
                index += 1
                continue
            index += self.step(index)
        self.flush()
        return self.out

    def step(self, index: int) -> int:
        """Handle the line at `index`; returns how many items it consumed."""
        item = self.items[index]
        command = item.command
        assert command is not None
        short = command.short_name
        following = self.items[index + 1] if index + 1 < len(self.items) else None
        if command.returns and following is not None and following.command is not None and \
                following.command.short_name == "SET_RVAR" and \
                following.index not in self.excluded and \
                isinstance(following.operands[0], VarRef) and \
                (not self.lines_known or following.line == item.line):
            self.read_into(item, following)
            return 2
        if self.level == "expressions":
            if short == "VAR_CALCULATE" and self.calculate(item):
                return 1
            if short in ("IF", "FOR") and self.condition(item):
                return 1
        self.flush()
        self.emit(self.single(item))
        return 1

    def single(self, item: Item) -> Statement:
        """One line as one statement (its target noted, for merging later steps)."""
        assert item.command is not None
        short = item.command.short_name
        text = self.writer.statement(item.command, item.operands)
        ref = {"SET_VAR": 0, "VAR_CALCULATE": 3}.get(short)
        target = item.operands[ref] if ref is not None else None
        return Statement(text, [item.index], item.line, block_role(item.command),
                         target=target if isinstance(target, VarRef) else None)

    def read_into(self, read: Item, store: Item) -> None:
        """A value-returning read and the SET_RVAR after it."""
        assert read.command is not None
        dest = store.operands[0]
        assert isinstance(dest, VarRef)
        query = Query(self.writer.query(read.command, read.operands))
        if self.level == "expressions" and self.is_temp(dest):
            if dest.index in self.pending:
                self.flush()
            self.pending[dest.index] = (query, [read.index, store.index], read.line)
            return
        self.flush()
        self.emit(Statement(f"VAR{dest.index} = {query.text}", [read.index, store.index],
                            read.line, target=dest, expr=query))

    def calculate(self, item: Item) -> bool:
        """VAR_CALCULATE at the expressions level: into a temporary (kept pending), or into a
        variable, taking pending temporaries as operands and merging steps computed in the
        target itself. False: write the line on its own. Each rule mirrors the compiler's
        `lower_into`: a complex right side always goes through a fresh temporary; a complex
        left side is computed in the target itself unless the right side reads the target."""
        left, code, right, dest = item.operands
        op = self.writer.calc_symbol.get(code) if isinstance(code, int) else None
        if op is None or not isinstance(dest, VarRef) or \
                not (is_value(left) and is_value(right)):
            return False
        into_temp = self.is_temp(dest)
        if into_temp and dest.index in self.pending and left != dest:
            return False  # a pending value overwritten unread: write everything plainly
        right_expr = self.take(right, item.line) if right != dest else None
        right_tree = right_expr or self.writer.leaf(right)
        chained = left == dest if into_temp else \
            left != dest and dest.index in variables_in(right_tree)
        left_expr = self.take(left, item.line) if chained else None
        consumed = {ref.index for ref, expr in ((left, left_expr), (right, right_expr))
                    if expr is not None and isinstance(ref, VarRef)}
        if not into_temp and set(self.pending) - consumed:
            return False  # something else is pending: keep the order, write plainly
        if not consumed and not isinstance(left, VarRef) and not isinstance(right, VarRef):
            return False  # two constants: only the raw spelling keeps them apart
        expr = Bin(op, left_expr or self.writer.leaf(left), right_tree)
        taken = sorted(i for ref in consumed for i in self.pending.pop(ref)[1])
        if into_temp:
            self.pending[dest.index] = (expr, [*taken, item.index], item.line)
            return True
        if left == dest and self.merge_into_previous(dest, op, right_tree, item, taken):
            return True
        self.emit(Statement(f"VAR{dest.index} = {render_expr(expr)}", [*taken, item.index],
                            item.line, target=dest, expr=expr))
        return True

    def merge_into_previous(self, dest: VarRef, op: str, right: Expr, item: Item,
                            taken: list[int]) -> bool:
        """`VARd = (previous expression) op right`, when the previous statement computed a
        complex value into VARd from the same source line (the compiler's in-place step)."""
        if not self.out or not self.lines_known:
            return False
        last = self.out[-1]
        if last.target != dest or last.expr is None or not is_complex(last.expr) or \
                last.line != item.line or last.role or dest.index in variables_in(right):
            return False
        expr = Bin(op, last.expr, right)
        self.out[-1] = Statement(f"VAR{dest.index} = {render_expr(expr)}",
                                 [*last.items, *taken, item.index], last.line, target=dest,
                                 expr=expr)
        return True

    def condition(self, item: Item) -> bool:
        """IF / FOR whose operands the compiler computed into temporaries."""
        assert item.command is not None
        ops = item.operands
        positions = (0, 2) if item.command.short_name == "IF" else (0,)
        texts: list[str | None] = [None] * len(ops)
        consumed: set[int] = set()
        for position in positions:
            operand = ops[position]
            expr = self.take(operand, item.line)
            if expr is not None and isinstance(operand, VarRef):
                texts[position] = render_expr(expr)
                consumed.add(operand.index)
        if not consumed or set(self.pending) - consumed:
            return False
        taken = sorted(i for ref in consumed for i in self.pending.pop(ref)[1])
        text = self.writer.statement(item.command, ops, texts)
        self.emit(Statement(text, [*taken, item.index], item.line, block_role(item.command)))
        return True


def lift(items: Sequence[Item], writer: Writer, temps: range, level: str,
         excluded: dict[int, str]) -> list[Statement]:
    """Statements for a program's items at one lifting level ("expressions" or "lines");
    undecodable items are added to `excluded`."""
    return _Lifter(items, writer, temps, level, excluded).run()


# ------------------------------------------------------------------------------ rendering
def _with_comment(text: str, comment: str) -> str:
    """A line with its source comment two spaces after it, as `mpc fmt` lays comments out,
    so the disassembly is already in the canonical layout."""
    if not comment:
        return text
    return f"{text}  # {comment}"


def _body_lines(body: Sequence[Statement], temps: range, indent: int = 4) -> list[
        tuple[str, Statement]]:
    """Indented statement lines, blank lines where the source had a gap."""
    out: list[tuple[str, Statement]] = []
    depth = 0
    previous: int | None = None
    for statement in body:
        if statement.role in ("close", "middle"):
            depth = max(0, depth - 1)
        # labels stand at the program's edge, as `mpc fmt` lays them out
        pad = "" if statement.text.startswith("LABEL ") else " " * (indent + 4 * depth)
        if previous is not None and statement.line is not None and statement.line > previous + 1:
            out.append(("", statement))
        notes: list[str] = []
        if statement.line is not None:
            notes.append(f"line {statement.line}")
        if statement.comment is not None:
            notes.append(f"not rebuilt: {statement.comment}")
        elif _touches_pool(statement.text, temps):
            notes.append("mpc: ignore[W104]")
        out.append((_with_comment(pad + statement.text, "  ".join(notes)), statement))
        if statement.role in ("open", "middle"):
            depth += 1
        if statement.line is not None:
            previous = statement.line
    return out


def _touches_pool(text: str, temps: range) -> bool:
    import re

    return any(int(n) in temps for n in re.findall(r"\bVAR(\d+)\b", text))


def _header(program: FlashProgram, name: str | None) -> str:
    head = f"{program.kind.upper()} {program.slot}" + (f" {name}" if name else "")
    where = program.where(0)
    note = f"from {where}" if where else ""
    if program.name and name is None:
        note = (note + "; " if note else "") + f"image name {program.name!r} is not usable here"
    return _with_comment(head, note)


def _footer(program: FlashProgram) -> str:
    last = len(program.frames) - 1
    line = program.lines[last] if last < len(program.lines) else None
    return _with_comment(f"END {program.kind.upper()}", f"line {line}" if line else "")


def _program_lines(text: ProgramText, temps: range) -> list[tuple[str, Statement | None]]:
    lines: list[tuple[str, Statement | None]] = [(_header(text.program, text.name), None)]
    lines += _body_lines(text.body, temps)
    lines.append((_footer(text.program), None))
    return lines


def _render_program(text: ProgramText, temps: range) -> str:
    return "\n".join(line for line, _ in _program_lines(text, temps)) + "\n"


def _file_header(image: FlashImage, origin: str, target: str, temps: range) -> str:
    options = [f"--target {target}"]
    if image.word_order != 0:
        options.append(f"--word-order {image.word_order}")
    if temps != DEFAULT_TEMPS:
        options.append(f"--temp-vars {temps.start}-{temps.stop - 1}")
    build = f"build {image.build_id}, " if image.build_id else ""
    return (f"# Disassembled by mpc disasm from {origin}\n"
            f"# {build}{len(image.programs)} program{'s' if len(image.programs) != 1 else ''}, "
            f"word order {image.word_order}\n"
            f"# Rebuild with: mpc build FILE {' '.join(options)}\n\n")


# ------------------------------------------------------------------------------ verification
def _stubs(image: FlashImage, names: dict[tuple[str, int], str], own: FlashProgram) -> str:
    """Empty programs with the other programs' slots and names, so CALL name resolves."""
    out = []
    for program in image.programs:
        key = (program.kind, program.slot)
        if program is own or key not in names:
            continue
        out.append(f"{program.kind.upper()} {program.slot} {names[key]}\n"
                   f"END {program.kind.upper()}\n")
    return "".join(out)


def _expected(program: FlashProgram, excluded: dict[int, str]) -> list[list[int]]:
    return [f for i, f in enumerate(program.frames) if i not in excluded]


def _rebuilt(result: BuildResult, program: FlashProgram) -> list[list[int]] | None:
    for built in result.programs:
        if (built.program.kind, built.placement.slot) == (program.kind, program.slot):
            return built.frames
    return None


def _disassemble_program(program: FlashProgram, items: list[Item],
                         names: dict[tuple[str, int], str], catalogue: Catalogue,
                         options: Options, image: FlashImage) -> ProgramText:
    """Lift, rebuild and compare; fall back to one statement per line, and turn lines the
    compiler refuses into comments, until the program rebuilds to its frames."""
    writer = Writer(catalogue, names, _label_names(items))
    name = names.get((program.kind, program.slot))
    stubs = _stubs(image, names, program)
    excluded: dict[int, str] = {}

    def attempt(level: str) -> tuple[ProgramText, BuildResult]:
        body = lift(items, writer, options.temps, level, excluded)
        text = ProgramText(program, name, body, excluded)
        source = _render_program(text, options.temps) + stubs
        return text, compile_source(source, CHECK_NAME, options)

    text, result = attempt("expressions")
    if result.ok and _rebuilt(result, program) == _expected(program, excluded):
        return text
    for _ in range(len(items) + 1):
        text, result = attempt("lines")
        if result.ok:
            break
        rows = _program_lines(text, options.temps)
        newly = False
        for diagnostic in result.diagnostics:
            if diagnostic.severity is not Severity.ERROR or diagnostic.span.file != CHECK_NAME:
                continue
            row = diagnostic.span.line - 1
            statement = rows[row][1] if 0 <= row < len(rows) else None
            if statement is None or statement.comment is not None:
                continue
            for index in statement.items:
                if index not in excluded:
                    excluded[index] = f"{diagnostic.code} {diagnostic.message}"
                    newly = True
        if not newly:
            break
    if excluded:
        full, full_result = attempt("expressions")
        if full_result.ok and _rebuilt(full_result, program) == _expected(program, excluded):
            return full
        text, result = attempt("lines")
    return text


def _whole_build_problems(source: str, image: FlashImage, texts: list[ProgramText],
                          options: Options) -> list[str]:
    """Rebuild the whole output once and name every program that differs."""
    result = compile_source(source, CHECK_NAME, options)
    if not result.ok:
        errors = [d for d in result.diagnostics if d.severity is Severity.ERROR]
        return [f"the output does not rebuild: its line {d.span.line}: {d.code} {d.message}"
                for d in errors]
    problems = []
    if image.init is not None and (result.init is None
                                   or result.init.frames != image.init.frames):
        problems.append("INIT: the disassembly rebuilds to other frames")
    if image.triggers is not None:
        def plain(entries: Sequence[dict[str, object]]) -> list[dict[str, object]]:
            return [{k: v for k, v in e.items() if k != "line"} for e in entries]

        if result.triggers is None or plain(result.triggers.entries) != \
                plain(image.triggers.entries):
            problems.append("TRIGGERS: the disassembly rebuilds to another trigger table")
    for text in texts:
        program = text.program
        rebuilt = _rebuilt(result, program)
        expected = _expected(program, text.excluded)
        if rebuilt != expected:
            where = _first_difference(rebuilt or [], expected)
            problems.append(f"{program.label}: the disassembly rebuilds to other frames "
                            f"(first difference at frame {where})")
    return problems


def _first_difference(rebuilt: list[list[int]], expected: list[list[int]]) -> int:
    for index, (a, b) in enumerate(zip(rebuilt, expected, strict=False)):
        if a != b:
            return index
    return min(len(rebuilt), len(expected))
