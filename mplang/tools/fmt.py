"""The `.mp` formatter: one canonical layout, every token and comment kept.

The layout is computed from the parser's own tokens, never from regular expressions over the
text, so strings, comments and the keyword/name distinction are exactly what the compiler
sees. Indentation follows the block structure the way `mplang.lang.structure` reads it
(also when a block is unbalanced), so the layout shows the compiler's reading. Before a
result is returned its tokens are compared with the input's: a formatter bug can never turn
into a changed program.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any, Literal, cast, get_args

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedInput

from mplang.ir import catalogue as catalogue_module
from mplang.ir.scope import KEYWORDS
from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink
from mplang.lang.parser import parse_text
from mplang.lang.structure import normalise as normalise_block_spelling

KeywordCase = Literal["upper", "lower"]
KEYWORD_CASES: tuple[str, ...] = get_args(KeywordCase)
OPTION_KEYS = ("indent", "keyword-case")
MAX_INDENT = 16
COMMENT_GAP = "  "  # between code and a comment at the end of its line


class FormatOptionsError(ValueError):
    """Formatter settings that cannot be used (unknown key, wrong type, value out of range)."""


class SourceNotFormattable(Exception):
    """The source has syntax errors: it is left as it is and these diagnostics say why."""

    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        super().__init__(f"{len(diagnostics)} syntax error(s)")
        self.diagnostics = diagnostics


class FormatterBug(RuntimeError):
    """The formatted text would not hold the input's tokens: never written anywhere."""


@dataclass(frozen=True)
class FormatOptions:
    """How the canonical layout is configured: spaces per block level, keyword case."""

    indent: int = 4
    keyword_case: KeywordCase = "upper"

    def __post_init__(self) -> None:
        if isinstance(self.indent, bool) or not isinstance(self.indent, int) \
                or not 1 <= self.indent <= MAX_INDENT:
            raise FormatOptionsError(f"indent must be a whole number of spaces from 1 to "
                                     f"{MAX_INDENT}, not {self.indent!r}")
        if self.keyword_case not in KEYWORD_CASES:
            raise FormatOptionsError(f"keyword-case must be one of {', '.join(KEYWORD_CASES)}, "
                                     f"not {self.keyword_case!r}")

    @classmethod
    def from_mapping(cls, table: Mapping[str, Any], *, where: str = "[fmt]") -> FormatOptions:
        """Options from a plain mapping such as the `[fmt]` table of `mpc.toml`
        (keys `indent`, `keyword-case`); anything else is refused with a message that
        starts with `where`."""
        unknown = sorted(set(table) - set(OPTION_KEYS))
        if unknown:
            raise FormatOptionsError(f"{where}: unknown key {unknown[0]!r} (known keys: "
                                     f"{', '.join(OPTION_KEYS)})")
        indent = table.get("indent", cls.indent)
        keyword_case = table.get("keyword-case", cls.keyword_case)
        try:
            return cls(indent=indent, keyword_case=keyword_case)
        except FormatOptionsError as exc:
            raise FormatOptionsError(f"{where}: {exc}") from None


# ------------------------------------------------------------------------- parsing


@cache
def _line_parser() -> tuple[Lark, list[Token]]:
    """The compiler's grammar, kept as a token tree of one line (every token; the comment,
    which the grammar ignores, collected aside).

    The comment list is shared by every parse of this process: `_parse_line` clears it first.
    Lines are parsed one at a time so that only one small tree is alive at a time: a tree of
    a whole long file keeps the garbage collector busy for longer than the parse takes.
    """
    grammar = resources.files("mplang.grammar").joinpath("mplang.lark").read_text("utf-8")
    comments: list[Token] = []

    def collect(comment: Token) -> Token:
        comments.append(comment)
        return comment

    parser = Lark(grammar, parser="lalr", lexer="contextual", start="line",
                  maybe_placeholders=True, keep_all_tokens=True,
                  lexer_callbacks={"COMMENT": collect})
    return parser, comments


@dataclass
class _Line:
    """One source line: its statement tree and/or comment, as the parser saw them."""

    statement: Tree[Token] | None = None
    comment: str | None = None


def _parse_line(text: str) -> _Line:
    if not text:
        return _Line()
    parser, comments = _line_parser()
    comments.clear()
    try:
        tree = parser.parse(text)
    except UnexpectedInput as exc:
        raise FormatterBug(f"the parser refused a line the compiler accepts: {exc}") from None
    statement = next((child for child in tree.children if isinstance(child, Tree)), None)
    return _Line(statement, str(comments[0]).rstrip() if comments else None)


Signature = tuple[tuple[str, str], ...]


def _signature(line: _Line, catalogue: catalogue_module.Catalogue) -> Signature:
    """The tokens of a line as the formatter must keep them: keywords and command names
    compared without case, every other token and the comment exactly."""
    tokens: list[tuple[str, str]] = []
    if line.statement is not None:
        for token in _tokens(line.statement):
            text = str(token)
            cased = token.type in KEYWORDS or (token.type == "NAME"
                                               and catalogue.lookup(text) is not None)
            tokens.append((token.type, text.upper() if cased else text))
    if line.comment is not None:
        tokens.append(("COMMENT", line.comment))
    return tuple(tokens)


def _tokens(tree: Tree[Token]) -> list[Token]:
    """The tokens of a statement tree in source order, without recursion (brackets nest a
    tree level each)."""
    found: list[Token] = []
    pending: list[Tree[Token] | Token | None] = [tree]
    while pending:
        node = pending.pop()
        if isinstance(node, Token):
            found.append(node)
        elif isinstance(node, Tree):
            pending.extend(reversed(node.children))
    return found


# ---------------------------------------------------------------- block structure


def _statement_depths(statements: list[ast.Statement]) -> tuple[dict[int, int], dict[int, int]]:
    """Per source line: the block depth of its statement, and the depth of the code after it
    (where a comment on its own line belongs).

    Mirrors the recovery of `mplang.lang.structure`: a header inside a program closes it,
    NEXT / END IF close the innermost matching block and whatever is open inside it, and an
    unmatched closer or a FOR/IF outside a program changes nothing.
    """
    stack: list[str] = []  # "program", "for", "if"
    depth_of: dict[int, int] = {}
    after: dict[int, int] = {}
    for raw in statements:
        statement = normalise_block_spelling(raw)
        line = raw.span.line
        match statement:
            case ast.ProgramHeader() | ast.InitHeader() | ast.InterruptsHeader() | \
                    ast.TriggersHeader():
                stack = ["program"]
                depth = 0
            case ast.End(what="mp" | "isr" | "init" | "interrupts" | "triggers"):
                stack = []
                depth = 0
            case ast.ForStmt() | ast.IfStmt() | ast.WhileStmt() | ast.RepeatStmt():
                depth = len(stack)
                if stack:
                    stack.append("if" if isinstance(statement, ast.IfStmt) else
                                 "while" if isinstance(statement, ast.WhileStmt) else
                                 "repeat" if isinstance(statement, ast.RepeatStmt) else "for")
            case ast.Next() | ast.End(what="for" | "if" | "while" | "repeat"):
                kind = statement.what if isinstance(statement, ast.End) else "for"
                if kind in stack:
                    while stack.pop() != kind:
                        pass
                depth = len(stack)
            case ast.Else():
                depth = len(stack) - 1 if stack and stack[-1] == "if" else len(stack)
            case ast.LabelStmt():
                depth = max(len(stack) - 1, 0)  # labels stand out at their program's edge
            case _:
                depth = len(stack)
        depth_of[line] = depth
        after[line] = len(stack)
    return depth_of, after


# ----------------------------------------------------------------------- rendering


class _Renderer:
    """Turns statement trees into canonical text, with the configured keyword case."""

    def __init__(self, options: FormatOptions) -> None:
        self.case: Callable[[str], str] = (str.upper if options.keyword_case == "upper"
                                           else str.lower)
        self.catalogue = catalogue_module.load()

    def command_name(self, token: Token) -> str:
        """A command or read name takes the keyword case; any other name stays as written."""
        text = str(token)
        return self.case(text) if self.catalogue.lookup(text) is not None else text

    def token(self, token: Token) -> str:
        return self.case(str(token)) if token.type in KEYWORDS else str(token)

    def statement(self, tree: Tree[Token]) -> str:
        children = [c for c in tree.children if c is not None]
        if tree.data == "command":
            name, args = cast(Token, children[0]), children[1:]
            head = self.command_name(name)
            exprs = [a for a in args if isinstance(a, Tree)]
            only = exprs[0].children if len(exprs) == 1 else []
            if len(only) == 1 and isinstance(only[0], Tree) and only[0].data == "group":
                return head + self.expr(only[0])  # NAME(a, b): the argument list form
            return f"{head} {', '.join(self.expr(e) for e in exprs)}" if exprs else head
        parts = [self.expr(c) if isinstance(c, Tree) and c.data not in ("on_call", "on_words")
                 else self.statement(c) if isinstance(c, Tree) else self.token(c)
                 for c in children]
        return " ".join(parts)

    def expr(self, tree: Tree[Token]) -> str:
        children = [c for c in tree.children if c is not None]
        match tree.data:
            case "expr":  # operands with their signs, and binary operators, flat
                text = ""
                expect_operand = True
                for child in children:
                    if isinstance(child, Tree):
                        text += self.expr(child)
                        expect_operand = False
                    elif expect_operand and child.type in ("MINUS", "PLUS"):
                        text += str(child)  # a sign, written against its operand
                    elif expect_operand:
                        text += self.command_name(child) if child.type == "NAME" else str(child)
                        expect_operand = False
                    else:
                        text += f" {child} "
                        expect_operand = True
                return text
            case "number":
                return str(children[0])
            case "call":
                return self.command_name(cast(Token, children[0])) + self.arguments(children[1:])
            case "group":
                return self.arguments(children)
        raise FormatterBug(f"unknown expression form {tree.data!r}")

    def arguments(self, bracketed: list[Tree[Token] | Token]) -> str:
        """`( a , b )` -> `(a, b)`: the commas are the only tokens between the items."""
        items = [self.expr(c) for c in bracketed if isinstance(c, Tree)]
        return f"({', '.join(items)})"


# ------------------------------------------------------------------------ the API


def _split_lines(text: str) -> tuple[list[str], str]:
    """Lines as the compiler reads them (carriage returns before a newline dropped, lines of
    any whitespace blank), and the file's newline convention (that of its first line break)."""
    first_break = text.find("\n")
    newline = "\r\n" if first_break > 0 and text[first_break - 1] == "\r" else "\n"
    lines = [line.rstrip("\r") for line in text.split("\n")]
    return [line if line.strip() else "" for line in lines], newline


def format_source(text: str, options: FormatOptions | None = None, *,
                  name: str = "<input>.mp") -> str:
    """The canonical layout of one source text.

    Raises SourceNotFormattable (with the compiler's diagnostics, `name` as the file) when
    the text has syntax errors. Unbalanced blocks are laid out as the compiler reads them.
    """
    options = options or FormatOptions()
    sink = DiagnosticSink()
    statements = parse_text(text, name, sink)
    if sink.errors:
        raise SourceNotFormattable(sink.sorted())
    lines, newline = _split_lines(text)
    depth_of, depth_after = _statement_depths(statements)
    renderer = _Renderer(options)
    out: list[str] = []
    kept: list[Signature] = []
    body_depth = 0
    for number, text_line in enumerate(lines, start=1):
        line = _parse_line(text_line)
        if line.statement is None and line.comment is None:
            if out and out[-1]:
                out.append("")  # blank lines group code: keep one of each run
            continue
        kept.append(_signature(line, renderer.catalogue))
        if line.statement is None:
            depth = body_depth
            code = line.comment or ""
        else:
            depth = depth_of.get(number, body_depth)
            body_depth = depth_after.get(number, body_depth)
            code = renderer.statement(line.statement)
            if line.comment is not None:
                code += COMMENT_GAP + line.comment
        out.append(" " * (options.indent * depth) + code)
    while out and not out[-1]:
        out.pop()
    _check_same_tokens(kept, out, renderer.catalogue)
    return newline.join(out) + newline if out else ""


def _check_same_tokens(kept: list[Signature], formatted: list[str],
                       catalogue: catalogue_module.Catalogue) -> None:
    """Refuse a result whose lines hold other tokens than the input's non-blank lines (case
    of keywords and command names aside): the formatter may only move whitespace and drop
    blank lines, and a comment stays on its line (`# mpc: ignore` silences that line)."""
    written = [_signature(_parse_line(line), catalogue) for line in formatted if line]
    if written != kept:
        raise FormatterBug("the formatted text does not hold the same tokens as the source")
