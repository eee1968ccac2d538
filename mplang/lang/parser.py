"""Text -> flat list of line statements, with every syntax error reported at once.

A whole file is parsed in one LALR pass, its tokens from the hand-written tokenizer
(`mplang.lang.tokenizer`, the fast path). If that fails, the text is parsed again with
lark's own contextual lexer, whole, then (still failing) every line on its own with the
grammar's `line` start symbol, so one run reports all bad lines, not only the first; the
good lines still reach the later passes. Lark's tables come from the user cache dir
(`cached_lark`).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

from lark import Lark, Token, Transformer
from lark import __version__ as LARK_VERSION
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError

from mplang.lang import ast, packagedata
from mplang.lang.builder import Rules, SyntaxProblem
from mplang.lang.caches import user_cache_dir
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.digest import sha256
from mplang.lang.limits import (
    MAX_EXPRESSION_DEPTH,
    expression_depth,
    too_deep,
)
from mplang.lang.tokenizer import FastLexer, Refused

PARSE_HOOKS: list[Callable[[str], object]] = []
"""Called with the file name before each parse (tests count parses with it)."""

# What the user sees instead of lark's terminal names.
TOKEN_WORDS = {
    "NAME": "a name", "INT": "a number", "STRING": "a string", "CMP": "a comparison",
    "_NL": "end of line", "$END": "end of line", "LPAR": "'('", "RPAR": "')'",
    "COMMA": "','", "EQUAL": "'='", "PLUS": "'+'", "MINUS": "'-'", "STAR": "'*'",
    "SLASH": "'/'", "AMP": "'&'", "BAR": "'|'", "THEN": "THEN", "AT": "'@'",
    "DI_PIN": "a DI channel (DI 8.0)", "CONDITION": "an interrupt factor or trigger condition",
}


_log: list[tuple[str, list[Any], Any, int]] | None = None
"""While `parse_recorded` runs: each builder call, its arguments, its result and the line
offset of its tokens (`recipes.Call`)."""


def _spread(builder: Rules, name: str, method: Callable[..., Any]
            ) -> Callable[[list[Any]], Any]:
    """Lark's callback for rule `name`: `method` called with the children spread, logged
    while a parse is recorded."""
    def spread(children: list[Any]) -> Any:
        made = method(*children)
        if _log is not None:
            _log.append((name, children, made, builder.line_offset))
        return made
    return spread


class _Builder(Rules, Transformer[Token, Any]):
    """The builder's rules (`mplang.lang.builder`) as lark's inline transformer.

    Lark calls a callback with the list of a rule's children: the instance holds, under
    each rule's name, a function that spreads the list into its method (one call, where
    lark's `v_args(inline=True)` makes three)."""

    def __init__(self, file: str, line_offset: int = 0) -> None:
        Transformer.__init__(self)
        Rules.__init__(self, file, line_offset)
        for name, value in vars(Rules).items():
            if callable(value) and not name.startswith("_"):
                self.__dict__[name] = _spread(self, name, getattr(self, name))


def cached_lark(grammar: str, name: str, **options: Any) -> Lark:
    """`Lark(grammar, parser="lalr", **options)`, its tables kept in the user cache dir
    (building them is most of lark's start-up).

    Lark checks the file against a hash of the grammar, its options and its own version and
    builds the tables when they differ or the file is damaged. It is written under a fresh
    name and renamed into place, so a concurrent run never reads half of one. Beside it the
    parser as lark made it is kept pickled (`_thaw`): read back three times as fast as lark
    deserialises its tables, which is most of the parse of an edited line on a build."""
    directory = user_cache_dir()
    if directory is None:
        return Lark(grammar, parser="lalr", **options)
    key = sha256(f"{grammar}\0{name}\0{LARK_VERSION}\0{sys.version_info[:2]}"
                         .encode()).hexdigest()[:20]
    target = directory / f"lark-{name}-{key}.pickle"
    state = directory / f"lark-{name}-{key}.state"
    state_key = _state_key(grammar, name, options)
    thawed = _thaw(state, state_key, options.get("transformer"))
    if thawed is not None:
        return thawed
    if target.is_file():
        lark = Lark(grammar, parser="lalr", cache=str(target), **options)
        _freeze(lark, state, state_key, options.get("transformer"))
        return lark
    try:
        directory.mkdir(parents=True, exist_ok=True)
        import tempfile  # only a run that builds the tables needs it

        descriptor, scratch = tempfile.mkstemp(dir=directory, prefix=".lark-", suffix=".tmp")
        os.close(descriptor)
        os.unlink(scratch)  # lark writes it when it has built the tables
    except OSError:
        return Lark(grammar, parser="lalr", **options)
    lark = Lark(grammar, parser="lalr", cache=scratch, **options)
    with contextlib.suppress(OSError):  # lark could not write it: built all the same
        os.replace(scratch, target)
    _freeze(lark, state, state_key, options.get("transformer"))
    return lark


def _state_key(grammar: str, name: str, options: dict[str, Any]) -> str:
    """What a pickled parser depends on: the grammar, lark's version, the options but the
    transformer (given again when read) and the code whose objects its state holds (the
    lexer's: this module's and the tokenizer's source, read as `frontcache` reads them; not
    through `frontcache`, which imports the statement cache, which imports this module)."""
    from mplang.lang import caches

    code: list[bytes] = []
    for module in ("parser", "tokenizer"):
        try:
            code.append(packagedata.read_bytes("mplang.lang", module + ".py"))
        except OSError:  # an install without sources: mpc's version (in every key) stands
            code.append(module.encode())
    shown = sorted((k, repr(v)) for k, v in options.items() if k != "transformer")
    return caches.digest("lark state 2", *code, grammar, name, LARK_VERSION,
                         repr(shown))


def _freeze(lark: Lark, path: Path, key: str, transformer: Transformer[Any, Any] | None
            ) -> None:
    """Keep `lark` pickled at `path` under `key`: its callbacks (lambdas lark makes from
    the transformer) and the transformer left out, lark's Shift and Reduce (compared by
    identity) and modules by name; silently nothing when it cannot."""
    import io
    import pickle
    import types

    from lark.parsers.lalr_analysis import Reduce, Shift

    from mplang.lang import caches

    named = {id(Shift): "Shift", id(Reduce): "Reduce", id(lark._callbacks): "callbacks",
             id(lark._parse_tree_builder): "tree"}
    if transformer is not None:
        named[id(transformer)] = "transformer"

    class _Pickler(pickle.Pickler):
        def persistent_id(self, obj: Any) -> object:
            name = named.get(id(obj))
            if name is not None:
                return name
            if isinstance(obj, types.ModuleType):
                return ("module", obj.__name__)
            return None

    stream = io.BytesIO()
    try:
        _Pickler(stream, protocol=pickle.HIGHEST_PROTOCOL).dump(lark)
    except Exception:  # a lark that holds what cannot be pickled: lark's cache serves
        return
    caches.store(path, key, stream.getvalue())


def _thaw(path: Path, key: str, transformer: Transformer[Any, Any] | None) -> Lark | None:
    """The parser `_freeze` kept at `path` under `key`, its callbacks made again for
    `transformer` (as lark makes them when it loads its tables); None when absent, damaged
    or of another key."""
    import importlib
    import io
    import pickle

    from lark.parsers.lalr_analysis import Reduce, Shift

    from mplang.lang import caches

    held = caches.load(path, key)
    if type(held) is not bytes:
        return None
    callbacks: dict[str, Any] = {}
    known = {"Shift": Shift, "Reduce": Reduce, "transformer": transformer,
             "callbacks": callbacks, "tree": None}

    class _Unpickler(pickle.Unpickler):
        def persistent_load(self, pid: Any) -> object:
            if type(pid) is str and pid in known:
                return known[pid]
            if type(pid) is tuple and len(pid) == 2 and pid[0] == "module":
                return importlib.import_module(pid[1])
            raise pickle.UnpicklingError(f"unknown persistent id {pid!r}")

    try:
        lark = _Unpickler(io.BytesIO(held)).load()
        if not isinstance(lark, Lark):
            return None
        lark.options.transformer = transformer
        lark._prepare_callbacks()  # the callbacks lark's own load makes
        callbacks.update(lark._callbacks)  # the one dict the parser's state shares
        lark._callbacks = callbacks
    except Exception:
        return None
    return lark


def _grammar() -> str:
    """The grammar's text, read as the front-end key reads it (`packagedata`: a parse on a
    front-cache miss loads neither `importlib.resources` nor `zipfile`)."""
    return packagedata.read_text("mplang.grammar", "mplang.lark")


@cache
def _parser() -> tuple[Lark, _Builder]:
    """Lark with lark's own contextual lexer: the reference, and the parser of the error
    path (its messages are the ones the tests pin). One per process; the inline builder is
    re-pointed at each file before use."""
    builder = _Builder("<none>")
    lark = cached_lark(_grammar(), "reference", lexer="contextual", start=["start", "line"],
                       maybe_placeholders=True, transformer=builder)
    return lark, builder


@cache
def _fast_parser() -> tuple[Lark, _Builder]:
    """Lark fed by the hand-written tokenizer (`mplang.lang.tokenizer`): the fast path for
    text that parses."""
    builder = _Builder("<none>")
    lark = cached_lark(_grammar(), "fast", lexer=FastLexer, start=["start"],
                       maybe_placeholders=True, transformer=builder)
    return lark, builder


def _describe_expected(expected: set[str]) -> str:
    """Turn terminal names into words, most useful first: values, then keywords, then
    punctuation."""
    values = sorted(TOKEN_WORDS[t] for t in expected if t in TOKEN_WORDS and not
                    TOKEN_WORDS[t].startswith("'"))
    punctuation = sorted(TOKEN_WORDS[t] for t in expected if t in TOKEN_WORDS and
                         TOKEN_WORDS[t].startswith("'"))
    keywords = sorted(t for t in expected if t not in TOKEN_WORDS and t.isalpha())
    if len(keywords) > 5:
        keywords = ["a statement keyword"]
    shown = values + keywords + punctuation
    return ", ".join(shown) if shown else "something else"


def _report(err: UnexpectedInput, file: str, line_no: int, text: str,
            sink: DiagnosticSink) -> None:
    """A syntax error's E101, with the hint `syntax_hints` has for the line (imported here:
    it reads its TOML table, which a parse of text without an error never needs)."""
    from mplang.lang.syntax_hints import character_hint, token_hint

    col = err.column if isinstance(err.column, int) and err.column > 0 else 1
    if isinstance(err, UnexpectedToken) and err.token.type in ("_NL", "$END"):
        col = len(text.rstrip()) + 1  # point just past the last character
    end = col + 1
    if isinstance(err, UnexpectedToken) and err.token.type not in ("_NL", "$END"):
        # the whole offending token (its first line), as far as the line reaches
        first = str(err.token).split("\n", 1)[0]
        end = max(end, min(col + len(first), len(text) + 1))
    span = Span(file, line_no, col, end)
    if isinstance(err, UnexpectedCharacters):
        char = text[col - 1] if 0 < col <= len(text) else "?"
        message, hint = character_hint(text, col) or (
            f"unexpected character {char!r}", "remove it, or write a comment with '#' or '//'")
        sink.add("E101", span, message, hint=hint)
        return
    if isinstance(err, UnexpectedToken):
        token = err.token
        if token.type in ("_NL", "$END"):
            found = "end of line"
        elif token.type in ("NAME", "INT", "STRING") or (token.type.isalpha() and len(token) > 1):
            kind = {"NAME": "name", "INT": "number", "STRING": "string"}.get(token.type, "keyword")
            found = f"{kind} {str(token)!r}"
        else:
            found = repr(str(token))
        expected = _describe_expected(set(err.accepts or err.expected) - {"$END"}
                                      | ({"_NL"} if "$END" in (err.accepts or err.expected)
                                         else set()))
        accepted = set(err.accepts or err.expected)
        hint = ("compare with '==' (a single '=' assigns)" if str(token) == "=" and
                "CMP" in accepted else
                "separate arguments with ','" if "COMMA" in accepted and token.type in
                ("NAME", "INT", "STRING") else
                "one statement per line; see docs/language.md for the statement forms")
        message, hint = token_hint(text, str(token)) or (
            f"unexpected {found}; expected {expected}", hint)
        sink.add("E101", span, message, hint=hint)
        return
    sink.add("E101", span, "syntax error")


_BLOCK_WORD = re.compile(r"\s*([A-Za-z]+)\b(?:\s+([A-Za-z]+)\b)?")


def _placeholder(text: str, span: Span) -> list[ast.Statement]:
    """Stand-in for a line that failed to parse but opens or closes a block.

    Keeping the block keyword keeps the structure balanced, so one typo in an IF line is not
    followed by a cascade of "IF not closed" reports. Operands are harmless dummies; the
    build has already failed with E101.
    """
    match = _BLOCK_WORD.match(text)
    if not match:
        return []
    first, second = match.group(1).lower(), (match.group(2) or "").lower()
    zero = ast.Num(0, span)
    made: dict[str, ast.Statement] = {
        "if": ast.IfStmt(zero, "==", zero, span), "for": ast.ForStmt(ast.Num(1, span), span),
        "else": ast.Else(span), "next": ast.Next(span),
        "mp": ast.ProgramHeader("mp", None, None, span),
        "isr": ast.ProgramHeader("isr", None, None, span),
        "init": ast.InitHeader(span), "triggers": ast.TriggersHeader(span),
        "interrupts": ast.InterruptsHeader("?", span, span),
    }
    if first == "end" and second in ("mp", "isr", "if", "for", "init", "interrupts",
                                     "triggers"):
        return [ast.End(second, span)]
    return [made[first]] if first in made else []


def _shallow(statement: ast.Statement, sink: DiagnosticSink) -> list[ast.Statement]:
    """`statement`, or after E107 a stand-in whose expressions are plain numbers: nothing
    nested beyond MAX_EXPRESSION_DEPTH reaches a later pass. Block openers and CONSTs stay
    (no cascade of unbalanced blocks or unknown names); assignments and commands go."""
    deep = too_deep(statement)
    if deep is None:
        return [statement]
    sink.add("E107", statement.span, f"the expression is nested more than "
             f"{MAX_EXPRESSION_DEPTH} levels deep, more than the compiler follows",
             hint="split it into several assignments or CONSTs")
    zero, one = ast.Num(0, deep.span), ast.Num(1, deep.span)
    match statement:
        case ast.Const():
            return [statement.replace(value=zero)]
        case ast.IfStmt() | ast.WhileStmt():
            return [statement.replace(left=zero, right=zero)]
        case ast.ForStmt() | ast.RepeatStmt():
            return [statement.replace(count=one)]
        case ast.Command() if statement.name.upper().removeprefix("RSM_MACRO_") \
                .removeprefix("ETM_MACRO_") in ("IF", "FOR"):
            return [statement.replace(args=[zero if expression_depth(a) > MAX_EXPRESSION_DEPTH
                                             else a for a in statement.args])]
    return []


def _bounded(statements: list[ast.Statement], text: str, sink: DiagnosticSink,
             first: int = 1) -> list[ast.Statement]:
    """The statements with E107 stand-ins for too-deep expressions (`text` starting at line
    `first`). Only lines longer than the depth bound can hold one (every level takes a
    character), so only they are walked."""
    long_lines = {number for number, line in enumerate(text.split("\n"), start=first)
                  if len(line) > MAX_EXPRESSION_DEPTH}
    if not long_lines:
        return statements
    kept: list[ast.Statement] = []
    for statement in statements:
        if statement.span.line in long_lines:
            kept.extend(_shallow(statement, sink))
        else:
            kept.append(statement)
    return kept


def parse_text(text: str, file: str, sink: DiagnosticSink) -> list[ast.Statement]:
    """Parse a whole source text; syntax errors go to `sink`, good lines are returned."""
    if PARSE_HOOKS:
        for hook in PARSE_HOOKS:
            hook(file)
    fast, fast_builder = _fast_parser()
    fast_builder.file, fast_builder.line_offset = file, 0
    _forget_calls()
    try:
        result: list[ast.Statement] = fast.parse(text, start="start")  # type: ignore[assignment]
        return _bounded(result, text, sink)
    except (UnexpectedInput, VisitError, SyntaxProblem, Refused):
        pass
    return _parse_slowly(text, file, sink)


def parse_recorded(text: str, file: str, sink: DiagnosticSink
                   ) -> tuple[list[ast.Statement], list[tuple[str, list[Any], Any, int]]]:
    """`parse_text`, and the builder calls that made its statements (`recipes.record`
    reads them): those of the attempt that gave them (a failed attempt's are dropped)."""
    global _log
    calls: list[tuple[str, list[Any], Any, int]] = []
    _log = calls
    try:
        return parse_text(text, file, sink), calls
    finally:
        _log = None


def _forget_calls() -> None:
    """A parse attempt starts: the calls of a failed one made nothing that is returned."""
    if _log:
        _log.clear()


def _parse_slowly(text: str, file: str, sink: DiagnosticSink) -> list[ast.Statement]:
    """The text with lark's own lexer: whole (the tokenizer may have refused something lark
    takes), else line by line, every bad line reported."""
    parser, builder = _parser()
    builder.file, builder.line_offset = file, 0
    _forget_calls()
    try:
        result: list[ast.Statement] = parser.parse(text, start="start")  # type: ignore[assignment]
        return _bounded(result, text, sink)
    except (UnexpectedInput, VisitError, SyntaxProblem):
        pass
    _forget_calls()  # line by line now: each line's calls with its own offset
    statements: list[ast.Statement] = []
    for index, line_text in enumerate(text.split("\n")):
        line_text = line_text.rstrip("\r")
        if not line_text.strip():
            continue
        builder.line_offset = index
        try:
            found: list[ast.Statement] = parser.parse(line_text, start="line")  # type: ignore[assignment]
            # bounded line by line: its E107 comes in line order among the E101s, as the
            # statement cache (`linecache`) reports the lines
            statements.extend(_bounded(found, line_text, sink, index + 1))
        except UnexpectedInput as err:
            _report(err, file, index + 1, line_text, sink)
            statements.extend(_placeholder(line_text, Span(file, index + 1)))
        except (VisitError, SyntaxProblem) as err:
            problem = err.orig_exc if isinstance(err, VisitError) else err
            if not isinstance(problem, SyntaxProblem):
                raise
            _report_problem(problem, file, index, sink)
            del problem  # its traceback holds this frame: a cycle through every local
            statements.extend(_placeholder(line_text, Span(file, index + 1)))
    return statements


def _report_problem(problem: SyntaxProblem, file: str, index: int,
                    sink: DiagnosticSink) -> None:
    column = problem.token.column or 1
    sink.add(problem.code, Span(file, index + 1, column, column + len(str(problem.token))),
             problem.message, hint=problem.hint)
