"""How big a source may make the compiler's trees: bounds checked once, in the front end.

Every later pass (names, folding, lowering, the formatter, the language server, the family
compilers) walks expressions and blocks recursively. Rather than make each of them iterative,
the front end refuses what no program needs and what those walks could not follow: numbers
longer than any device value (E108), expressions nested more than MAX_EXPRESSION_DEPTH levels
(E107) and blocks nested more than MAX_BLOCK_DEPTH levels (E310/E311, far beyond the device's
7). The checks here are iterative, so the bound holds whatever the input. JSON the tools read
(images, memory files) is bounded the same way before it is decoded (`load_json`).
"""

from __future__ import annotations

import json
import re
import stat
from pathlib import Path
from typing import Any

from mplang.lang import ast

# Node levels of one expression: `a + b` is 2. A 100-term sum lowers to 99 VAR_CALCULATE
# lines; deeper trees are generated text, never a program.
MAX_EXPRESSION_DEPTH = 100
# Blocks (FOR, IF, WHILE, REPEAT) inside one program; the device allows 7 of a kind.
MAX_BLOCK_DEPTH = 64
# Significant digits of a number literal: 20 decimal digits hold any 64-bit value, and 16 hex
# digits after 0x; a device value needs at most 10 (32 bits).
MAX_DECIMAL_DIGITS = 20
MAX_HEX_DIGITS = 16


def number_too_long(text: str) -> str | None:
    """Why the literal `text` (decimal, or hex after 0x) is refused, or None if it is fine.

    Checked on the text, before any conversion: Python refuses to convert more than 4,300
    decimal digits, and a huge hex value would break every message that prints it."""
    hexadecimal = text[:2].lower() == "0x"
    digits = (text[2:] if hexadecimal else text).lstrip("0")
    limit = MAX_HEX_DIGITS if hexadecimal else MAX_DECIMAL_DIGITS
    if len(digits) <= limit:
        return None
    shown = text if len(text) <= 24 else f"{text[:10]}...{text[-6:]}"
    return (f"the number {shown} has {len(digits)} significant digits; numbers have at most "
            f"{limit}{' after 0x' if hexadecimal else ''} (device values are 32-bit)")


# Numbers in a native listing (.fbs, .csim): decimal runs (also register and variable
# numbers such as D12; not the digits after a decimal point), 0x hex and WinProladder's 0100H.
_NATIVE_NUMBER = re.compile(r"0[xX][0-9A-Fa-f]+|[0-9][0-9A-Fa-f]*[Hh](?![0-9A-Za-z_])"
                            r"|(?<![.0-9])[0-9]+")


def long_number(line: str) -> tuple[int, str] | None:
    """The first number of a native listing's line that is too long (0-based column, why):
    checked on the text before the line is parsed, as `number_too_long` does for .mp."""
    for match in _NATIVE_NUMBER.finditer(line):
        text = match.group()
        if text[-1] in "Hh" and not text.isdigit():
            digits = text[:-1].lstrip("0")
            if len(digits) > MAX_HEX_DIGITS:
                return match.start(), (f"the number {text[:10]}...{text[-6:]} has {len(digits)} "
                                       f"significant digits; numbers have at most "
                                       f"{MAX_HEX_DIGITS} in hex (device values are 32-bit)")
            continue
        problem = number_too_long(text)
        if problem is not None:
            return match.start(), problem
    return None


def expression_depth(expr: ast.Expr, limit: int = MAX_EXPRESSION_DEPTH) -> int:
    """Node levels of `expr`, counted without recursion; stops as soon as it passes `limit`."""
    deepest = 0
    pending: list[tuple[ast.Expr, int]] = [(expr, 1)]
    while pending:
        node, depth = pending.pop()
        if depth > deepest:
            deepest = depth
            if deepest > limit:
                return deepest
        match node:
            case ast.BinOp(left=left, right=right):
                pending += ((left, depth + 1), (right, depth + 1))
            case ast.Neg(operand=operand):
                pending.append((operand, depth + 1))
            case ast.Group(items=items) | ast.Call(args=items):
                pending += ((item, depth + 1) for item in items)
    return deepest


def statement_expressions(statement: ast.Statement) -> list[ast.Expr]:
    """The expressions a line statement holds, in source order."""
    match statement:
        case ast.Const(value=value) | ast.Assign(value=value):
            return [value]
        case ast.ForStmt(count=count) | ast.RepeatStmt(count=count):
            return [count]
        case ast.IfStmt(left=left, right=right) | ast.WhileStmt(left=left, right=right):
            return [left, right]
        case ast.Command(args=args):
            return list(args)
    return []


def too_deep(statement: ast.Statement) -> ast.Expr | None:
    """The first expression of `statement` nested beyond MAX_EXPRESSION_DEPTH, if any."""
    return next((e for e in statement_expressions(statement)
                 if expression_depth(e) > MAX_EXPRESSION_DEPTH), None)


# Arrays and objects inside each other in JSON the tools read; images nest 4 deep.
MAX_JSON_DEPTH = 32
# The size of a JSON file the tools read (an image, a macro memory file, the flash record):
# a full-device image is about 2 MB, so this only stops a wrong file being read whole.
MAX_JSON_BYTES = 64 * 1024 * 1024
_JSON_STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"')
_JSON_BRACKET = re.compile(r"[\[\]{}]")


def load_json(text: str, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """`json.loads(text)` for files a user hands over: ValueError (json.JSONDecodeError for
    bad syntax) also when arrays and objects nest more than `max_depth` deep, checked before
    decoding, so the decoder and every walk of the result stay shallow."""
    depth = deepest = 0
    for bracket in _JSON_BRACKET.finditer(_JSON_STRING.sub("", text)):
        depth += 1 if bracket.group() in "[{" else -1
        deepest = max(deepest, depth)
        if deepest > max_depth:
            raise ValueError(f"arrays and objects nested more than {max_depth} deep")
    return json.loads(text)


def read_json_file(path: Path, errors: str = "replace") -> Any:
    """`load_json` of a file a user hands over, bounded before it is read: OSError when it
    cannot be read, ValueError when it is not a regular file (a FIFO or a device would block
    or never end) or is larger than MAX_JSON_BYTES, and as `load_json`."""
    info = path.stat()
    if not stat.S_ISREG(info.st_mode):
        raise ValueError("not a regular file")
    if info.st_size > MAX_JSON_BYTES:
        raise ValueError(f"{info.st_size:,} bytes, more than the {MAX_JSON_BYTES:,} mpc "
                         "reads of a JSON file")
    return load_json(path.read_bytes().decode("utf-8", errors=errors))
