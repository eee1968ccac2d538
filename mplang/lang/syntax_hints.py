"""Syntax errors that deserve their own words: forms other languages have and mplang does not
(`VAR1 += 1`, `IF a > 0 AND b > 0`, `ELSE IF`, `TIMER 1.5`). The parser's generic "one
statement per line" would mislead there (issue 15 item 6); each gets a message naming the
form and a hint with what to write instead, from docs/language.md."""

from __future__ import annotations

import re
import tomllib
from functools import cache
from importlib import resources

COMPOUND = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*([-+*/&|])=\s*(.*?)\s*(?:#.*|//.*)?$")
CONDITION = re.compile(r"\s*(IF|WHILE)\b", re.IGNORECASE)
ELSE_IF = re.compile(r"\s*ELSE\s+IF\b", re.IGNORECASE)
DECIMAL = re.compile(r"[0-9]+\.[0-9]*")
FIRST_WORD = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)")
VENDOR = re.compile(r"^(?:RSM_|ETM_)?(?:MACRO_)?")


def token_hint(text: str, token: str) -> tuple[str, str] | None:
    """(message, hint) for an unexpected token on the line `text`, or None for the
    parser's own words."""
    compound = COMPOUND.match(text)
    if compound is not None and token == "=":
        name, op, rest = compound.groups()
        rest = rest or "VALUE"
        return (f"'{op}=' is not an mplang operator: assignments are `NAME = expression`",
                f"write {name} = {name} {op} {rest}")
    condition = CONDITION.match(text)
    if condition is not None and token.upper() in ("AND", "OR", "&&", "||"):
        word = condition.group(1).upper()
        return (f"AND and OR are not supported in conditions: {word} compares two values "
                "(a CMP b)",
                "for AND nest the IFs (IF a > 0, then IF b > 0 inside it, each closed by its "
                "own END IF); for OR test the second in the ELSE of the first, or set a "
                "variable in two IFs and test it")
    if ELSE_IF.match(text) is not None and token.upper() == "IF":
        return ("ELSE IF is not an mplang form: ELSE stands alone on its line",
                "write ELSE, then the IF on the next line inside it, closed by its own "
                "END IF before the outer END IF")
    return None


def character_hint(text: str, col: int) -> tuple[str, str] | None:
    """(message, hint) for an unexpected character at 1-based `col` of `text`: a decimal
    point in a number names the argument's unit from the catalogue."""
    if not 0 < col <= len(text) or text[col - 1] != ".":
        return None
    start = col - 1
    while start > 0 and text[start - 1].isdigit():
        start -= 1
    number = DECIMAL.match(text, start)
    if number is None or start == col - 1:
        return None
    message = f"{number.group()!r}: mplang numbers are whole numbers (no decimal point)"
    first = FIRST_WORD.match(text)
    doc = _param_doc(first.group(1), text[:start].count(",")) if first else None
    if doc is None:
        return message, "write a whole number in the unit the argument counts in"
    name, what = doc
    return message, f"write {name} as a whole number: {what}"


@cache
def _params() -> dict[str, list[tuple[str, str]]]:
    """Each macro command's (parameter name, doc) list, by mplang name, from the
    catalogue's data file (read only for this message: lang/ does not import ir/)."""
    text = resources.files("mplang.stdlib").joinpath("m8194h", "commands.toml") \
        .read_text("utf-8")
    found: dict[str, list[tuple[str, str]]] = {}
    for command in tomllib.loads(text).get("command", []):
        name = str(command.get("name", "")).upper()
        short = VENDOR.sub("", name).replace("_MACRO_", "_", 1)
        params = [(str(p.get("name", "")), str(p.get("doc", "")))
                  for p in command.get("param", [])]
        found.setdefault(short, params)
    return found


def _param_doc(command: str, index: int) -> tuple[str, str] | None:
    """`TIMER's varNo` and its doc for the `index`-th argument of `command`, if known."""
    params = _params().get(command.upper())
    if params is None or not 0 <= index < len(params):
        return None
    name, doc = params[index]
    return f"{command.upper()}'s {name}", doc
