"""Hover, completion, go to definition and slot budgets over an `Analysis`, without pygls.

Every function takes 0-based code-point positions and returns plain data; `mplang.tools.lsp.server`
turns it into LSP messages. The word under the cursor is resolved the way the compiler
resolves names (labels and programs by the statement they stand in, then CONST, ALIAS,
program names, variables, commands, axes and the parameter's symbolic constants).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

from mplang.ir.catalogue import Command, Param
from mplang.ir.lower import BVAR_RE, PROGRAM_RE, VAR_RE
from mplang.tools.lsp.analysis import Analysis, Definition, IncludeLine, ProgramBlock
from mplang.tools.lsp.positions import Location, Pos, Range, line_range
from mplang.tools.lsp.tokens import Cursor, Token, cursor_at

# Keyword statements: their form and the macro command each lowers to (docs/language.md).
KEYWORD_FORMS: dict[str, tuple[str, str | None]] = {
    "CONST": ("CONST NAME = expression: a compile-time integer, global to the build", None),
    "ALIAS": ("ALIAS name = VARn: a name for a device variable, global to the build", None),
    "VAR": ("VAR name [@ VARn]: a variable of its own, shared with the host; the compiler "
            "picks a free VARn of the pool unless `@ VARn` pins it", None),
    "INCLUDE": ('INCLUDE "file.mp": joins that file\'s CONSTs, ALIASes and programs', None),
    "MP": ("MP [number] [name] ... END MP: a macro program; without a number the linker "
           "picks the slot", None),
    "ISR": ("ISR number [name] ... END ISR: an interrupt service routine", None),
    "FOR": ("FOR count ... NEXT: repeat (a variable count is counted down to 0)", "FOR"),
    "NEXT": ("NEXT: closes the innermost FOR", "NEXT"),
    "END FOR": ("END FOR: closes the innermost FOR, like NEXT", "NEXT"),
    "IF": ("IF a CMP b ... [ELSE ...] END IF, CMP one of < > <= >= == !=", "IF"),
    "THEN": ("THEN: optional after the comparison of an IF", None),
    "ELSE": ("ELSE: the branch taken when the IF comparison is false", "ELSE"),
    "END IF": ("END IF: closes the innermost IF", "END_IF"),
    "END MP": ("END MP: closes the program (the closing line counts in the budget)",
               "MP_CLOSE"),
    "END ISR": ("END ISR: closes the routine (the closing line counts in the budget)",
                "MP_ISR_CLOSE"),
    "EXIT": ("EXIT: leave this program, back to its caller", "EXIT_MACRO"),
    "EXIT FOR": ("EXIT FOR: leave the innermost FOR loop", "EXIT_FOR"),
    "LABEL": ("LABEL name: a jump target, 0..3 or a name; four per program, never inside "
              "FOR or IF", "LABEL"),
    "GOTO": ("GOTO name: jump to a LABEL of the same program", "GOTO"),
    "CALL": ("CALL MPn / CALL name: run another MP and come back", "MP_CALL"),
    "TERMINATE": ("TERMINATE: stop the program (and its callers)", "MP_TERMINATE"),
}
STATEMENT_KEYWORDS = {
    "mp": ["FOR", "NEXT", "IF", "ELSE", "END IF", "EXIT", "EXIT FOR", "LABEL", "GOTO", "CALL",
           "TERMINATE", "END MP"],
    "isr": ["IF", "ELSE", "END IF", "EXIT", "TERMINATE", "END ISR"],
}
TOP_LEVEL_SNIPPETS = [
    ("CONST", "CONST ${1:NAME} = ${2:0}"),
    ("ALIAS", "ALIAS ${1:name} = VAR${2:0}"),
    ("VAR", "VAR ${1:name}"),
    ("INCLUDE", 'INCLUDE "${1:file.mp}"'),
    ("MP", "MP ${1:name}\n\t$0\nEND MP"),
    ("ISR", "ISR ${1:1} ${2:name}\n\t$0\nEND ISR"),
]
SCOPE_WORDS = {"mp": "MP", "isr": "ISR", "rtc": "real time (from the host)",
               "it": "initial table"}
MANUAL_PLACES = {"signature": "prototype", "table1": "Table 1", "appendix": "appendix",
                 "example": "example"}
MANUAL = "RS-M8194H API manual v3.1"
INCLUDE_FILES_SHOWN = 200


@dataclass(frozen=True)
class Target:
    """What a word in the source stands for."""

    kind: str  # command keyword const alias declared program slot label variable bvariable
    # axis symbol
    name: str
    command: Command | None = None
    definition: Definition | None = None
    program: ProgramBlock | None = None
    number: int | None = None
    param: Param | None = None
    path: Path | None = None


@dataclass(frozen=True)
class Hover:
    range: Range
    markdown: str


@dataclass(frozen=True)
class CompletionEntry:
    label: str
    kind: str  # command keyword variable constant axis label program value file snippet
    detail: str = ""
    documentation: str = ""  # markdown
    insert_text: str | None = None
    snippet: bool = False
    sort_group: int = 1  # lower groups are listed first


@dataclass(frozen=True)
class ProgramBudget:
    """The lens / inlay hint of one program header: `MP3: 41/64 lines`."""

    range: Range
    title: str


# ----------------------------------------------------------------------- the word under the cursor


def _cursor(analysis: Analysis, pos: Pos) -> Cursor | None:
    if not 0 <= pos.line < len(analysis.lines):
        return None
    return cursor_at(analysis.lines[pos.line], pos.character)


def _second_word(cursor: Cursor) -> str:
    code = [t for t in cursor.tokens if t.kind != "comment"]
    return code[1].upper if len(code) > 1 and code[1].kind == "name" else ""


def resolve(analysis: Analysis, line: int, cursor: Cursor, word: Token) -> Target | None:
    """What `word` (on 0-based `line`) names."""
    head, position, upper = cursor.head, cursor.position, word.upper
    catalogue, profile = analysis.catalogue, analysis.catalogue.profile
    if head in ("GOTO", "LABEL") and position == 1:
        program = analysis.program_at(line)
        found = program.labels.get(upper) if program else None
        return Target("label", word.text, definition=found, program=program)
    if head == "CALL" and position == 1:
        return _program_target(analysis, word.text, "mp")
    if head in ("MP", "ISR") and position in (1, 2):
        program = analysis.program_at(line)
        return Target("program", word.text, program=program) if program else None
    if word.kind == "int":
        return None
    if head in ("END", "EXIT") and position in (0, 1):
        second = _second_word(cursor)
        phrase = f"{head} {second}" if second else head
        if phrase in KEYWORD_FORMS:
            return Target("keyword", phrase)
    elif (position == 0 or upper == "THEN") and upper in KEYWORD_FORMS:
        return Target("keyword", upper)
    # In an argument, the parameter's own symbols come first, as in the compiler
    # (LINE_2D is a value of MIX_2D_CONTINUE's nType there, not the command).
    slot = cursor.argument()
    called = catalogue.lookup(slot.command) if slot else None
    if slot and called and slot.index < len(called.params):
        param = called.params[slot.index]
        if upper in param.symbols:
            return Target("symbol", word.text, command=called, param=param,
                          number=param.symbols[upper])
        if param.kind == "cmp_op" and upper in profile.cmp_symbols:
            return Target("symbol", word.text, command=called, param=param,
                          number=profile.cmp_ops[profile.cmp_symbols[upper]])
    if upper in analysis.consts:
        return Target("const", word.text, definition=analysis.consts[upper])
    if upper in analysis.aliases:
        return Target("alias", word.text, definition=analysis.aliases[upper])
    if upper in analysis.declared:
        return Target("declared", word.text, definition=analysis.declared[upper])
    if analysis.program_named(word.text) is not None:
        return Target("program", word.text, program=analysis.program_named(word.text))
    if (match := VAR_RE.fullmatch(upper)) is not None:
        return Target("variable", upper, number=int(match.group(1)))
    if (match := BVAR_RE.fullmatch(upper)) is not None:
        return Target("bvariable", word.text, number=int(match.group(1)))
    if PROGRAM_RE.fullmatch(upper) is not None:
        return _program_target(analysis, word.text, None)
    command = catalogue.lookup(upper)
    if command is not None:
        return Target("command", word.text, command=command)
    if profile.axis_code(upper) is not None:
        return Target("axis", word.text, number=profile.axis_code(upper))
    return None


def _program_target(analysis: Analysis, text: str, kind: str | None) -> Target:
    """`MP21`, `21` (after CALL) or a program name."""
    upper = text.upper()
    match = PROGRAM_RE.fullmatch(upper)
    if match or (upper.isdigit() and kind):
        slot_kind = match.group(1).lower() if match else str(kind)
        number = int(match.group(2) if match else upper)
        program = analysis.program_in_slot(slot_kind, number)
        if program is not None:
            return Target("program", text, program=program)
        return Target("slot", slot_kind, number=number)
    return Target("program", text, program=analysis.program_named(text))


def target_at(analysis: Analysis, pos: Pos) -> tuple[Token, Target] | None:
    cursor = _cursor(analysis, pos)
    if cursor is None or cursor.in_comment or cursor.word is None:
        return None
    target = resolve(analysis, pos.line, cursor, cursor.word)
    return (cursor.word, target) if target is not None else None


def _include_at(analysis: Analysis, pos: Pos) -> IncludeLine | None:
    return next((i for i in analysis.includes if i.range.contains(pos)), None)


# ----------------------------------------------------------------------------------- hover


def hover(analysis: Analysis, pos: Pos) -> Hover | None:
    include = _include_at(analysis, pos)
    if include is not None:
        state = "part of this build" if include.target in analysis.files else \
            "not part of this build: see its diagnostic"
        return Hover(include.range, f"`{include.target}` ({state})")
    found = target_at(analysis, pos)
    if found is None:
        return None
    word, target = found
    return Hover(line_range(pos.line, word.start, word.end), describe(analysis, target))


def describe(analysis: Analysis, target: Target) -> str:
    """Markdown for a hover."""
    profile = analysis.catalogue.profile
    match target.kind:
        case "command":
            assert target.command is not None
            return command_markdown(analysis, target.command)
        case "keyword":
            form, lowers_to = KEYWORD_FORMS[target.name]
            text = f"**{target.name}** (keyword)\n\n{form}"
            command = analysis.catalogue.macro_by_short.get(lowers_to or "")
            if command is not None:
                text += f"\n\nLowers to:\n\n{command_markdown(analysis, command)}"
            return text
        case "const":
            assert target.definition is not None
            value = analysis.const_values.get(target.definition.name.upper())
            shown = "no value (see the error on its line)" if value is None else f"{value:,}"
            return (f"**CONST {target.definition.name}** = {shown}\n\n"
                    f"`{target.definition.text}`\n\n{_where(analysis, target.definition)}")
        case "alias":
            assert target.definition is not None
            index = analysis.alias_targets.get(target.definition.name.upper())
            var = f"VAR{index}" if index is not None else "no variable (see its error)"
            return (f"**ALIAS {target.definition.name}** = {var}\n\n"
                    f"`{target.definition.text}`\n\n{_where(analysis, target.definition)}")
        case "declared":
            assert target.definition is not None
            key = target.definition.name.upper()
            index = analysis.alias_targets.get(key)
            pool = analysis.options.var_pool
            how = "pinned" if key in analysis.pinned else \
                f"the first free of the pool VAR{pool.start}..VAR{pool.stop - 1}"
            var = f"VAR{index} ({how})" if index is not None else "no variable (see its error)"
            return (f"**VAR {target.definition.name}** = {var}\n\n"
                    f"`{target.definition.text}`\n\n{_where(analysis, target.definition)}")
        case "program":
            return _program_markdown(analysis, target)
        case "slot":
            kind = target.name
            budget = profile.budget(kind, target.number or 0)
            if budget is None:
                return f"**{kind.upper()}{target.number}** does not exist on the device"
            return (f"**{kind.upper()}{target.number}**: a slot of {budget} lines; no program "
                    "of this build is in it (it may already be on the device)")
        case "label":
            owner = target.program.title if target.program else "no program"
            if target.definition is None:
                return f"**LABEL {target.name}**: not defined in {owner}"
            return (f"**LABEL {target.definition.name}** of {owner}\n\n"
                    f"{_where(analysis, target.definition)}")
        case "variable":
            return _variable_markdown(analysis, target.number or 0)
        case "bvariable":
            base = profile.var("byte_holding_base")
            return (f"**bVAR{target.number}**: byte variable, sent as "
                    f"{base + (target.number or 0):#x} (holding register "
                    f"{base + (target.number or 0)})")
        case "axis":
            code = target.number or 0
            return (f"**{target.name.upper()}**: axis code {code:#x} "
                    f"({' + '.join(profile.axis_name(code & 0xF))})")
        case "symbol":
            assert target.command is not None and target.param is not None
            return (f"**{target.name.upper()}** = {target.number} ({(target.number or 0):#x}): "
                    f"a value of `{target.param.name}` of {target.command.short_name}")
    return target.name


def _where(analysis: Analysis, definition: Definition) -> str:
    return f"defined at {_location_text(analysis, definition.location)}"


def _location_text(analysis: Analysis, location: Location) -> str:
    entry = analysis.files.get(location.path)
    name = entry.display if entry else str(location.path)
    return f"{name}:{location.range.start.line + 1}"


def _program_markdown(analysis: Analysis, target: Target) -> str:
    program = target.program
    if program is None:
        return f"**{target.name}**: no program of this name in the build"
    text = f"**{program.title}**"
    use = analysis.slot_use(program)
    if use is not None:
        text += f"\n\n{use.summary}"
    line = program.first_line + 1
    entry = analysis.files.get(program.path)
    return text + f"\n\ndefined at {entry.display if entry else program.path}:{line}"


def _variable_markdown(analysis: Analysis, index: int) -> str:
    profile = analysis.catalogue.profile
    count = profile.var("count")
    if index >= count:
        return f"**VAR{index}** does not exist: variables are VAR0..VAR{count - 1}"
    code = profile.var("macro_base") + index
    text = (f"**VAR{index}**: device variable, sent as {code:#010x} (holding register "
            f"{profile.var('holding_base') + 2 * index})")
    names = analysis.alias_names_of(index)
    if names:
        text += "\n\nALIAS: " + ", ".join(names)
    temps = analysis.options.temps
    if index in temps:
        text += (f"\n\nIn the compiler's temporary pool VAR{temps.start}..VAR{temps.stop - 1}"
                 ": expressions overwrite it")
    return text


def command_markdown(analysis: Analysis, command: Command) -> str:
    """A command's catalogue entry: parameters, scope, line cost, manual place."""
    short = command.short_name
    vendor = [command.name]
    if command.name.startswith("RSM_") and "et" in command.targets:
        vendor.append("ETM_" + command.name[4:])
    parts = [f"**{short}** ({' / '.join(vendor)})"]
    if command.summary:
        parts.append(command.summary)
    names = ", ".join(p.name for p in command.params)
    call = f"VARn = {short}({names})" if command.returns else f"{short} {names}".rstrip()
    parts.append(f"`{call}`")
    if command.params:
        rows = ["| parameter | type | accepts | |", "|---|---|---|---|"]
        rows += [f"| `{p.name}` | {p.type} | {param_accepts(analysis, p)} | {p.doc} |"
                 for p in command.params]
        parts.append("\n".join(rows))
    scope = ", ".join(SCOPE_WORDS[s] for s in ("mp", "isr", "rtc", "it") if s in command.scope)
    facts = [f"- Scope: {scope or 'host only (no macro form)'}",
             f"- Line cost: {command.line_cost} macro line"
             f"{'' if command.line_cost == 1 else f's (x{command.line_cost})'}"]
    if command.returns:
        facts.append("- Returns a value: stored with SET_RVAR")
    if command.code is not None:
        facts.append(f"- Sub-function code 0x{command.code:04X}")
    if command.targets != frozenset(("rs", "et")):
        facts.append("- Only on " + ", ".join(t.upper() + "-M8194H"
                                             for t in sorted(command.targets)))
    places = ", ".join(f"{MANUAL_PLACES.get(k, k)} line {v}" for k, v in command.lines.items())
    facts.append(f"- Manual: section {command.section} of the {MANUAL}"
                 + (f" ({places})" if places else ""))
    parts.append("\n".join(facts))
    if command.choice:
        parts.append(f"Reading taken: {command.choice}")
    return "\n\n".join(parts)


def param_accepts(analysis: Analysis, param: Param) -> str:
    """What a parameter takes, in words."""
    kind = param.kind
    profile = analysis.catalogue.profile
    words = {
        "axis": "axes (X, XY, ... XYZU)", "axis1": "one axis (X, Y, Z or U)",
        "axis1_or_none": "one axis or 0", "axis_it": "axes or INITIAL_ axes",
        "var": "a variable VARn", "calc_op": "an operator: " + " ".join(profile.calc_ops),
        "cmp_op": "a comparison: " + " ".join(profile.cmp_ops),
        "mp": "an MP (MPn or a name)", "isr": "an ISR (ISRn or a name)",
        "isr_or_none": "an ISR or 0", "label": "a label 0..3",
        "bvar": "bVARn or a number",
    }
    text = words.get(kind, "a number")
    if param.values:
        names = {v: k for k, v in param.symbols.items()}
        text = "one of " + ", ".join(f"{v} ({names[v]})" if v in names else str(v)
                                     for v in param.values)
    elif param.symbols:
        text += "; " + ", ".join(param.symbols)
    if param.min is not None or param.max is not None:
        low = "" if param.min is None else f"{param.min:,}"
        high = "" if param.max is None else f"{param.max:,}"
        text += f" ({low}..{high})"
    if param.var and kind != "var":
        text += ", or VARn"
    return text


# ------------------------------------------------------------------------------ definition


def definition(analysis: Analysis, pos: Pos) -> list[Location]:
    """Where the name under the cursor is defined (an INCLUDE: the file it names)."""
    include = _include_at(analysis, pos)
    if include is not None:
        readable = include.target in analysis.files or include.target.is_file()
        return [Location(include.target, line_range(0, 0, 0))] if readable else []
    found = target_at(analysis, pos)
    if found is None:
        return []
    _, target = found
    if target.definition is not None:
        return [target.definition.location]
    if target.kind == "program" and target.program is not None:
        return [Location(target.program.path, target.program.name_range)]
    return []


# ------------------------------------------------------------------------------ completion


def completion(analysis: Analysis, pos: Pos) -> list[CompletionEntry]:
    line = analysis.lines[pos.line] if 0 <= pos.line < len(analysis.lines) else ""
    cursor = cursor_at(line, pos.character)
    head, position = cursor.head, cursor.position
    if cursor.in_comment:
        return []
    if cursor.string is not None:
        return _include_files(analysis) if head == "INCLUDE" and position == 1 else []
    program = analysis.program_at(pos.line)
    if position == 0:
        return _statement_starts(analysis, program) if program else _top_level()
    if head in ("GOTO", "LABEL") and position == 1:
        return _labels(program) if head == "GOTO" else []
    if head == "CALL" and position == 1:
        return _programs(analysis, "mp")
    if head == "END" and position == 1:
        return [CompletionEntry(w, "keyword") for w in ("MP", "ISR", "IF", "FOR")]
    if head == "EXIT" and position == 1:
        return [CompletionEntry("FOR", "keyword", KEYWORD_FORMS["EXIT FOR"][0])]
    if head in ("MP", "ISR", "INCLUDE", "NEXT", "ELSE", "TERMINATE", "LABEL", "VAR"):
        return []
    if head == "ALIAS":
        return _variables(analysis, group=0) if cursor.after_equals() else []
    if head == "CONST":
        return _constants(analysis, 0) if cursor.after_equals() else []
    slot = cursor.argument()
    if slot is not None:
        command = analysis.catalogue.lookup(slot.command)
        if command is None or slot.index >= len(command.params):
            return []
        return _argument_values(analysis, command.params[slot.index], program)
    return [*_variables(analysis, 0), *_constants(analysis, 0), *_queries(analysis, program)]


def _snippet_of(command: Command) -> str:
    fields = ", ".join(f"${{{n}:{p.name}}}" for n, p in enumerate(command.params, start=1))
    return f"{command.short_name} {fields}" if fields else command.short_name


def _allowed(analysis: Analysis, command: Command, kind: str) -> bool:
    return kind in command.scope and analysis.options.target in command.targets and \
        command.short_name not in ("MP_CLOSE", "MP_ISR_CLOSE")


def _command_entry(analysis: Analysis, command: Command, insert: str) -> CompletionEntry:
    names = ", ".join(p.name for p in command.params)
    return CompletionEntry(command.short_name, "command", f"{command.short_name} {names}".strip(),
                           command_markdown(analysis, command), insert, snippet=True,
                           sort_group=2)


def _statement_starts(analysis: Analysis, program: ProgramBlock) -> list[CompletionEntry]:
    entries = [CompletionEntry(word, "keyword", KEYWORD_FORMS[word][0], sort_group=1)
               for word in STATEMENT_KEYWORDS[program.kind]]
    entries += [_command_entry(analysis, c, _snippet_of(c))
                for c in analysis.catalogue.macro_by_short.values()
                if _allowed(analysis, c, program.kind)]
    entries += _variables(analysis, 3)
    return entries


def _top_level() -> list[CompletionEntry]:
    return [CompletionEntry(word, "snippet", KEYWORD_FORMS[word][0], insert_text=snippet,
                            snippet=True) for word, snippet in TOP_LEVEL_SNIPPETS]


def _labels(program: ProgramBlock | None) -> list[CompletionEntry]:
    if program is None:
        return []
    return [CompletionEntry(d.name, "label", d.text, sort_group=0)
            for d in program.labels.values()]


def _programs(analysis: Analysis, kind: str) -> list[CompletionEntry]:
    entries: list[CompletionEntry] = []
    for program in analysis.programs:
        if program.kind != kind:
            continue
        use = analysis.slot_use(program)
        detail = use.summary if use else program.title
        if program.name:
            entries.append(CompletionEntry(program.name, "program", detail, sort_group=0))
        slot = program.number if program.number is not None else (use.slot if use else None)
        if slot is not None:
            entries.append(CompletionEntry(f"{kind.upper()}{slot}", "program",
                                           program.title, sort_group=1))
    return entries


def _variables(analysis: Analysis, group: int) -> list[CompletionEntry]:
    named = {**analysis.aliases, **analysis.declared}
    entries = [CompletionEntry(d.name, "variable",
                               f"VAR{analysis.alias_targets[key]}"
                               if key in analysis.alias_targets else d.text, sort_group=group)
               for key, d in named.items()]
    for index in sorted(analysis.variables_used):
        names = analysis.alias_names_of(index)
        entries.append(CompletionEntry(f"VAR{index}", "variable",
                                       "ALIAS " + ", ".join(names) if names else "",
                                       sort_group=group + 1))
    return entries


def _constants(analysis: Analysis, group: int) -> list[CompletionEntry]:
    entries = []
    for key, d in analysis.consts.items():
        value = analysis.const_values.get(key)
        entries.append(CompletionEntry(d.name, "constant",
                                       d.text if value is None else f"= {value:,}",
                                       sort_group=group))
    return entries


def _queries(analysis: Analysis, program: ProgramBlock | None) -> list[CompletionEntry]:
    """Value-returning reads, for the right-hand side of an assignment or an IF."""
    kind = program.kind if program else "mp"
    entries = []
    for command in analysis.catalogue.macro_by_short.values():
        if not command.returns or not _allowed(analysis, command, kind):
            continue
        fields = ", ".join(f"${{{n}:{p.name}}}" for n, p in enumerate(command.params, 1))
        insert = f"{command.short_name}({fields})" if fields else command.short_name
        entries.append(_command_entry(analysis, command, insert))
    return entries


def axis_names(analysis: Analysis) -> list[str]:
    """X Y Z U XY XZ ... XYZU: every Table 4 combination, in the manual's order."""
    letters = list(analysis.catalogue.profile.axes)
    return ["".join(combo) for size in range(1, len(letters) + 1)
            for combo in itertools.combinations(letters, size)]


def _argument_values(analysis: Analysis, param: Param,
                     program: ProgramBlock | None) -> list[CompletionEntry]:
    profile = analysis.catalogue.profile
    kind = param.kind
    entries = [CompletionEntry(name, "value", f"= {value}", sort_group=0)
               for name, value in param.symbols.items()]
    if kind.startswith("axis"):
        for name in axis_names(analysis):
            code = profile.axis_code(name) or 0
            single = len(name) == 1
            if kind in ("axis1", "axis1_or_none") and not single:
                continue
            if param.values and code not in param.values:
                continue
            entries.append(CompletionEntry(name, "axis", f"axis code {code:#x}",
                                           sort_group=0 if single else 1))
        return entries
    if kind == "cmp_op":
        entries += [CompletionEntry(name, "value", op, sort_group=0)
                    for name, op in profile.cmp_symbols.items()]
        return entries
    if kind in ("mp", "isr", "isr_or_none"):
        return entries + _programs(analysis, kind.removesuffix("_or_none"))
    if kind == "label":
        return entries + _labels(program)
    if kind == "var":
        return entries + _variables(analysis, 0)
    if kind in ("int", "float", "bvar"):
        entries += _constants(analysis, 1)
        if param.wire == 2:
            entries += _variables(analysis, 2)
    return entries


def _include_files(analysis: Analysis) -> list[CompletionEntry]:
    """`.mp` files next to the document and one directory down, as INCLUDE paths."""
    folder = analysis.path.parent
    found = sorted({*folder.glob("*.mp"), *folder.glob("*/*.mp")})
    return [CompletionEntry(path.relative_to(folder).as_posix(), "file")
            for path in found if path.resolve() != analysis.path][:INCLUDE_FILES_SHOWN]


# ----------------------------------------------------------------------------- budgets


def program_budgets(analysis: Analysis) -> list[ProgramBudget]:
    """Every MP/ISR header of the open document with its lines used against its budget."""
    budgets = []
    for program in analysis.programs:
        if program.path != analysis.path:
            continue
        use = analysis.slot_use(program)
        if use is not None:
            budgets.append(ProgramBudget(program.header_range, use.summary))
    return budgets
