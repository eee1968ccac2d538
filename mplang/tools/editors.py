"""Generate the VS Code grammar and language configuration (`editors/vscode/`).

Run `python -m mplang.tools.editors` after changing the grammar (grammar/mplang.lark), the command
catalogue (stdlib/m8194h/) or the warning-suppression comment; tests/tools/test_editors.py fails
while the committed files differ from what this writes. Keywords come from the lark grammar,
command names, symbolic constants and axis letters from `catalogue.load()`, so the editor
highlights exactly what the compiler reads.
"""

from __future__ import annotations

import json
import re
import sys
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from lark import Lark

from mplang.ir import catalogue
from mplang.ir.catalogue import VENDOR_PREFIXES, Catalogue, Command
from mplang.lang.diagnostics import SUPPRESS

ROOT = Path(__file__).resolve().parents[2]
VSCODE = ROOT / "editors" / "vscode"
GRAMMAR_FILE = VSCODE / "syntaxes" / "mplang.tmLanguage.json"
CONFIGURATION_FILE = VSCODE / "language-configuration.json"
SCOPE = "source.mplang"

# Every keyword of the grammar, by what it does; the generator stops while this table and the
# grammar's keywords differ.
KEYWORD_ROLES = {
    "MP": "program", "ISR": "program",
    "CONST": "declaration", "ALIAS": "declaration", "VAR": "declaration",
    "INCLUDE": "import",
    "END": "control", "FOR": "control", "NEXT": "control", "EXIT": "control", "IF": "control",
    "THEN": "control", "ELSE": "control", "LABEL": "control", "GOTO": "control",
    "CALL": "control", "TERMINATE": "control", "WHILE": "control", "REPEAT": "control",
    "INIT": "program", "INTERRUPTS": "program", "TRIGGERS": "program", "ON": "control",
}
# Terminals that outrank NAME without being keywords: `DI 8.0` in an ON line.
NOT_KEYWORDS = ("DI_PIN",)
KEYWORD_SCOPES = {"program": "storage.type.program.mplang",
                  "declaration": "storage.type.declaration.mplang",
                  "import": "keyword.control.import.mplang",
                  "control": "keyword.control.mplang"}
# The name a declaration keyword introduces.
DECLARED_NAME_SCOPES = {"CONST": "variable.other.constant.mplang",
                        "ALIAS": "variable.other.alias.mplang",
                        "VAR": "variable.other.declared.mplang"}

# Catalogue commands that are spellings of block structure and flow (structure.py turns
# them into the keyword statements): highlighted as control keywords, not as commands.
CONTROL_COMMANDS = ("FOR", "NEXT", "IF", "ELSE", "END_IF", "EXIT_FOR", "EXIT_MACRO", "GOTO",
                    "LABEL", "MP_CALL", "MP_TERMINATE", "MP_CLOSE", "MP_ISR_CLOSE")
# Blocks fold from the keywords that `END` closes in the grammar (`end_stmt`); besides
# `END FOR`, `NEXT` closes a FOR. Raw command spellings of block words (structure.py).
BLOCK_CLOSERS = ("NEXT",)
RAW_BLOCK_OPENERS = ("FOR", "IF")
RAW_BLOCK_CLOSERS = ("NEXT", "END_IF")
DEDENTING_WORDS = ("ELSE",)  # closes one branch and opens the next
AXIS_PREFIXES = ("AXIS_", "INITIAL_")

NUMBER = r"0[xX][0-9A-Fa-f]+|[0-9]+"
IDENTIFIER = r"[A-Za-z_][A-Za-z0-9_]*"


class GeneratorError(Exception):
    """The grammar or catalogue holds something the editor files have no place for."""


@cache
def _lark() -> Lark:
    text = resources.files("mplang.grammar").joinpath("mplang.lark").read_text("utf-8")
    return Lark(text, parser="lalr", lexer="contextual", start=["start", "line"])


def block_keywords() -> list[str]:
    """The keywords that open a block: those `END` closes (`end_stmt: END (MP | ISR | ...)`)."""
    words = [rule.expansion[1].name for rule in _lark().rules
             if rule.origin.name == "end_stmt" and len(rule.expansion) == 2]
    if not words:
        raise GeneratorError("the grammar has no `end_stmt: END (...)` rule any more")
    return words


def grammar_keywords() -> list[str]:
    """The keyword terminals of grammar/mplang.lark (`FOR.2: /for\\b/i`), in grammar order."""
    lark = _lark()
    name_priority = next(t.priority for t in lark.terminals if t.name == "NAME")
    words = []
    for terminal in lark.terminals:
        if terminal.priority <= name_priority or terminal.name in NOT_KEYWORDS:
            continue
        match = re.fullmatch(r"([a-z]+)\\b", terminal.pattern.value)
        if match is None or match.group(1).upper() != terminal.name:
            raise GeneratorError(f"keyword terminal {terminal.name} has an unexpected pattern "
                                 f"{terminal.pattern.value!r}")
        words.append(terminal.name)
    unknown = sorted(set(words) - set(KEYWORD_ROLES))
    stale = sorted(set(KEYWORD_ROLES) - set(words))
    if unknown or stale:
        raise GeneratorError("KEYWORD_ROLES of mplang/tools/editors.py does not match the "
                             f"grammar: "
                             f"keywords without a role {unknown}, roles without a keyword "
                             f"{stale}")
    undeclared = sorted(w for w in words if KEYWORD_ROLES[w] == "declaration"
                        and w not in DECLARED_NAME_SCOPES)
    if undeclared:
        raise GeneratorError(f"declaration keywords {undeclared} have no scope in "
                             f"DECLARED_NAME_SCOPES of mplang/tools/editors.py")
    return words


def caseless(word: str) -> str:
    """`End_if` -> `[Ee][Nn][Dd]_[Ii][Ff]`: VS Code ignores regex flags in folding markers."""
    return "".join(f"[{ch.upper()}{ch.lower()}]" if ch.isalpha() else re.escape(ch)
                   for ch in word)


def alternation(words: list[str] | tuple[str, ...]) -> str:
    """Longest first, so that no alternative stops at a shorter prefix of another."""
    return "|".join(sorted(set(words), key=lambda w: (-len(w), w)))


def _macro(cat: Catalogue, short: str) -> Command:
    command = cat.macro_by_short.get(short)
    if command is None:
        raise GeneratorError(f"{short} is not a macro command of the catalogue any more")
    return command


def _vendor_tail(cat: Catalogue, short: str) -> str:
    """`FIXED_MOVE` -> `MACRO_FIXED_MOVE`: the vendor name without its `RSM_`/`ETM_`."""
    name = _macro(cat, short).name.upper()
    prefix = next((p for p in VENDOR_PREFIXES if name.startswith(p)), None)
    if prefix is None:
        raise GeneratorError(f"catalogue name {name} has none of the prefixes {VENDOR_PREFIXES}")
    return name.removeprefix(prefix)


def vendor_spellings(cat: Catalogue, short: str) -> list[str]:
    """`FOR` -> `RSM_MACRO_FOR`, `ETM_MACRO_FOR`: the full names the compiler accepts too."""
    return [prefix + _vendor_tail(cat, short) for prefix in VENDOR_PREFIXES]


def command_pattern(cat: Catalogue, shorts: list[str]) -> str:
    """Short names and vendor names (`RSM_`/`ETM_` + the vendor tail) of some commands."""
    tails = [_vendor_tail(cat, s) for s in shorts]
    prefixes = "|".join(p.rstrip("_") for p in VENDOR_PREFIXES)
    return f"(?:{prefixes})_(?:{alternation(tails)})|{alternation(shorts)}"


def _command_groups(cat: Catalogue) -> tuple[list[str], list[str], list[str]]:
    """Macro command short names split into control spellings, value reads and the rest."""
    control = [_macro(cat, s).short_name for s in CONTROL_COMMANDS]
    queries = sorted(s for s, c in cat.macro_by_short.items() if c.returns and s not in control)
    plain = sorted(s for s, c in cat.macro_by_short.items()
                   if not c.returns and s not in control)
    return control, queries, plain


def symbol_names(cat: Catalogue) -> list[str]:
    """The manual's symbolic constants of macro command parameters (`LT`, `LPSAV`, ...)."""
    names = set(cat.profile.cmp_symbols)
    for command in cat.commands:
        if command.is_macro:
            for param in command.params:
                names |= set(param.symbols)
    return sorted(names)


def axis_pattern(cat: Catalogue) -> str:
    """Axis names: letters in bit order (X, XY, XZU, ...), optionally `AXIS_` / `INITIAL_`."""
    letters = sorted(cat.profile.axes, key=lambda letter: cat.profile.axes[letter])
    # One alternative per first letter, so that the match is never empty.
    names = "|".join(first + "".join(f"{later}?" for later in letters[i + 1:])
                     for i, first in enumerate(letters))
    return rf"\b(?:{'|'.join(AXIS_PREFIXES)})?(?:{names})\b"


def _words(words: list[str]) -> str:
    return rf"\b(?:{alternation(words)})\b"


def tm_grammar(cat: Catalogue) -> dict[str, Any]:
    """The TextMate grammar: line-start statement forms first, then tokens anywhere."""
    keywords = grammar_keywords()
    by_role: dict[str, list[str]] = {}
    for word in keywords:
        by_role.setdefault(KEYWORD_ROLES[word], []).append(word)
    control, queries, plain = _command_groups(cat)
    if SUPPRESS.groups != 1:
        raise GeneratorError("compiler.SUPPRESS must capture the code list as its only group")
    number = {"patterns": [{"include": "#numbers"}]}
    repository: dict[str, Any] = {
        "comments": {"patterns": [
            {"name": "comment.line.number-sign.mplang", "begin": "#",
             "beginCaptures": {"0": {"name": "punctuation.definition.comment.mplang"}},
             "end": "$", "patterns": [{"include": "#suppression"}]},
            {"name": "comment.line.double-slash.mplang", "begin": "//",
             "beginCaptures": {"0": {"name": "punctuation.definition.comment.mplang"}},
             "end": "$", "patterns": [{"include": "#suppression"}]},
        ]},
        "suppression": {
            "match": SUPPRESS.pattern,
            "name": "meta.directive.suppress.mplang",
            "captures": {"1": {"name": "constant.other.check-code.mplang"}},
        },
        "strings": {"patterns": [
            {"name": "string.quoted.double.mplang", "match": r'"[^"]*"'},
            {"name": "string.quoted.single.mplang", "match": r"'[^']*'"},
            {"name": "invalid.illegal.unterminated-string.mplang", "match": r"[\"'].*$"},
        ]},
        "program-header": {
            "match": (rf"(?i)^\s*({alternation(by_role['program'])})\b"
                      rf"(?:\s+({NUMBER})\b)?(?:\s+({IDENTIFIER}))?"),
            "captures": {"1": {"name": KEYWORD_SCOPES["program"]}, "2": number,
                         "3": {"name": "entity.name.function.mplang"}},
        },
        "block-end": {
            "match": rf"(?i)^\s*(END\s+(?:{alternation(block_keywords())}))\b",
            "captures": {"1": {"name": KEYWORD_SCOPES["control"]}},
        },
        "declarations": {"patterns": [
            {"match": rf"(?i)^\s*({word})\s+({IDENTIFIER})",
             "captures": {"1": {"name": KEYWORD_SCOPES["declaration"]},
                          "2": {"name": DECLARED_NAME_SCOPES[word]}}}
            for word in by_role["declaration"]
        ]},
        "labels": {
            "match": rf"(?i)^\s*(LABEL|GOTO)\s+({IDENTIFIER}|{NUMBER})\b",
            "captures": {"1": {"name": KEYWORD_SCOPES["control"]},
                         "2": {"name": "entity.name.label.mplang"}},
        },
        "calls": {
            "match": rf"(?i)^\s*(CALL)\s+({IDENTIFIER}|{NUMBER})\b",
            "captures": {"1": {"name": KEYWORD_SCOPES["control"]},
                         "2": {"name": "entity.name.function.mplang"}},
        },
        "statement-command": {
            "match": rf"(?i)^\s*({command_pattern(cat, plain)})\b",
            "captures": {"1": {"name": "support.function.command.mplang"}},
        },
        "keywords": {"patterns": [
            {"name": KEYWORD_SCOPES[role], "match": f"(?i){_words(words)}"}
            for role, words in by_role.items()
        ] + [{"name": KEYWORD_SCOPES["control"],
              "match": f"(?i)\\b(?:{command_pattern(cat, control)})\\b"}]},
        "queries": {
            "name": "support.function.query.mplang",
            "match": f"(?i)\\b(?:{command_pattern(cat, queries)})\\b",
        },
        "symbols": {
            "name": "support.constant.symbol.mplang",
            "match": f"(?i){_words(symbol_names(cat))}",
        },
        "commands": {
            "name": "support.function.command.mplang",
            "match": f"(?i)\\b(?:{command_pattern(cat, plain)})\\b",
        },
        "variables": {"patterns": [
            {"name": "variable.other.var.mplang", "match": r"(?i)\bVAR[0-9]+\b"},
            {"name": "variable.other.bvar.mplang", "match": r"(?i)\bBVAR[0-9]+\b"},
            {"name": "entity.name.function.program.mplang",
             "match": rf"(?i)\b(?:{alternation(by_role['program'])})[0-9]+\b"},
        ]},
        "axes": {"name": "constant.language.axis.mplang", "match": f"(?i){axis_pattern(cat)}"},
        "numbers": {"patterns": [
            {"name": "constant.numeric.integer.hexadecimal.mplang",
             "match": r"\b0[xX][0-9A-Fa-f]+\b"},
            {"name": "constant.numeric.integer.decimal.mplang", "match": r"\b[0-9]+\b"},
        ]},
        "operators": {"patterns": [
            {"name": "keyword.operator.comparison.mplang", "match": r"<=|>=|==|!=|<|>"},
            {"name": "keyword.operator.assignment.mplang", "match": "="},
            {"name": "keyword.operator.arithmetic.mplang", "match": r"[-+*/]"},
            {"name": "keyword.operator.bitwise.mplang", "match": r"[&|]"},
            {"name": "keyword.operator.pin.mplang", "match": "@"},
            {"name": "punctuation.separator.comma.mplang", "match": ","},
            {"name": "punctuation.section.parens.begin.mplang", "match": r"\("},
            {"name": "punctuation.section.parens.end.mplang", "match": r"\)"},
        ]},
    }
    order = ["comments", "strings", "program-header", "block-end", "declarations", "labels",
             "calls", "statement-command", "keywords", "queries", "symbols",
             "commands", "variables", "axes", "numbers", "operators"]
    assert set(order) == set(repository) - {"suppression"}
    return {
        "name": "mplang",
        "scopeName": SCOPE,
        "comment": "Generated by `python -m mplang.tools.editors` from grammar/mplang.lark and "
                   "stdlib/m8194h; do not edit by hand.",
        "fileTypes": ["mp"],
        "patterns": [{"include": f"#{name}"} for name in order],
        "repository": repository,
    }


def _line_start(patterns: list[str]) -> str:
    """A JavaScript regex (VS Code applies no flags) for a line starting with one of them."""
    return rf"^\s*(?:{'|'.join(patterns)})\b"


def _spellings(cat: Catalogue, keywords: tuple[str, ...], raw: tuple[str, ...]) -> list[str]:
    """Keywords plus the raw command spellings (`END_IF`, `RSM_MACRO_FOR`), each caseless."""
    words = [*keywords, *raw, *(v for short in raw for v in vendor_spellings(cat, short))]
    return [caseless(word) for word in dict.fromkeys(words)]


def language_configuration(cat: Catalogue) -> dict[str, Any]:
    """Comments, brackets, folding markers and indentation rules for VS Code."""
    blocks = tuple(block_keywords())
    end_block = caseless("END") + r"\s+(?:" + "|".join(caseless(w) for w in blocks) + ")"
    openers = _spellings(cat, blocks, RAW_BLOCK_OPENERS)
    closers = [end_block, *_spellings(cat, BLOCK_CLOSERS, RAW_BLOCK_CLOSERS)]
    middles = _spellings(cat, DEDENTING_WORDS, DEDENTING_WORDS)
    return {
        "comments": {"lineComment": "#"},
        "brackets": [["(", ")"]],
        "autoClosingPairs": [
            {"open": "(", "close": ")"},
            {"open": '"', "close": '"', "notIn": ["string", "comment"]},
            {"open": "'", "close": "'", "notIn": ["string", "comment"]},
        ],
        "surroundingPairs": [["(", ")"], ['"', '"'], ["'", "'"]],
        "folding": {"markers": {"start": _line_start(openers), "end": _line_start(closers)}},
        "indentationRules": {
            "increaseIndentPattern": _line_start(openers + middles),
            "decreaseIndentPattern": _line_start([caseless("END"), *closers[1:], *middles]),
        },
        "wordPattern": f"{NUMBER}|{IDENTIFIER}",
    }


def _json(document: dict[str, Any]) -> str:
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"


def generated() -> dict[Path, str]:
    """Every file this module writes, with its text."""
    cat = catalogue.load()
    return {GRAMMAR_FILE: _json(tm_grammar(cat)),
            CONFIGURATION_FILE: _json(language_configuration(cat))}


def main() -> int:
    if not (VSCODE / "package.json").is_file():
        print(f"mplang.tools.editors: {VSCODE} is not there: run this from a source checkout of "
              "mplang", file=sys.stderr)
        return 1
    try:
        files = generated()
    except GeneratorError as exc:
        print(f"mplang.tools.editors: {exc}", file=sys.stderr)
        return 1
    for path, text in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
