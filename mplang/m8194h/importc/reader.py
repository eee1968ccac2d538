"""Reading C text: a small tokenizer (no preprocessor, no compiler needed) and the grouping of
its tokens into statements, blocks, comments and blank lines (`events`), which is all the
importer needs to follow a C file.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property

CONTROL_WORDS = frozenset({"if", "while", "for", "switch"})
LONE_CONTROL_WORDS = frozenset({"else", "do"})
JUMP_WORDS = frozenset({"return", "break", "continue", "goto"})
TYPE_WORDS = frozenset({"BYTE", "WORD", "DWORD", "long", "int", "short", "char", "unsigned",
                        "signed", "float", "double", "void", "const", "volatile", "static",
                        "LONG", "INT", "SHORT", "UINT", "ULONG", "USHORT", "bool", "BOOL"})

TOKEN = re.compile(r"""
    (?P<nl>\r?\n)
  | (?P<ws>[ \t\f\v]+|\\\r?\n)
  | (?P<lcomment>//[^\r\n]*)
  | (?P<bcomment>/\*.*?\*/)
  | (?P<open_comment>/\*)
  | (?P<string>"(?:\\.|[^"\\\r\n])*")
  | (?P<char>'(?:\\.|[^'\\\r\n])+')
  | (?P<number>(?:0[xX][0-9a-fA-F]+|0[bB][01]+|[0-9]+\.?[0-9]*(?:[eE][+-]?[0-9]+)?
                 |\.[0-9]+(?:[eE][+-]?[0-9]+)?)[uUlLfF]*)
  | (?P<ident>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<punct><<=|>>=|->|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||[-+*/%&|^]=|::|.)
""", re.VERBOSE | re.DOTALL)
DIRECTIVE_START = re.compile(r"[ \t]*#")
"""A preprocessor line: `#` after nothing but blanks (matched at a line's start, so the cost
is that of the blanks, never of the rest of the file)."""


@dataclass(frozen=True, slots=True)
class Token:
    kind: str  # ident number string char punct comment directive
    text: str
    line: int
    col: int
    start: int
    end: int

    @property
    def end_line(self) -> int:
        return self.line + self.text.count("\n")


def tokenize(text: str) -> Iterator[Token]:
    """C tokens with positions; whitespace and newlines are dropped, comments and
    preprocessor lines kept. An unterminated comment runs to the end of the file."""
    line, line_start, pos = 1, 0, 0
    at_line_start = True
    while pos < len(text):
        if at_line_start:
            hash_mark = DIRECTIVE_START.match(text, pos)
            if hash_mark is not None:
                stripped = hash_mark.end() - 1
                end = _directive_end(text, stripped)
                yield Token("directive", text[stripped:end], line, stripped - line_start + 1,
                            stripped, end)
                newlines = text.count("\n", stripped, end)
                if newlines:
                    line += newlines
                    line_start = text.rindex("\n", stripped, end) + 1
                pos, at_line_start = end, False
                continue
        match = TOKEN.match(text, pos)
        assert match is not None  # the last alternative matches any character
        kind = match.lastgroup or "punct"
        value = match.group()
        if kind == "open_comment":
            kind, value = "comment", text[pos:] + "*/"
            match_end = len(text)
        else:
            match_end = match.end()
        if kind == "nl":
            line, line_start, at_line_start = line + 1, match_end, True
        elif kind == "ws":
            if "\n" in value:
                line, line_start = line + 1, match_end
        else:
            at_line_start = False
            if kind in ("lcomment", "bcomment"):
                kind = "comment"
            yield Token(kind, value, line, pos - line_start + 1, pos, match_end)
            if "\n" in value:
                line += value.count("\n")
                line_start = pos + value.rindex("\n") + 1
        pos = match_end


def _directive_end(text: str, start: int) -> int:
    """A preprocessor line ends at a newline not escaped by a backslash, or where a comment
    starts (the comment is a token of its own)."""
    pos = start
    in_string: str | None = None
    while pos < len(text):
        char = text[pos]
        if in_string:
            if char == "\\":
                pos += 2
                continue
            if char == in_string:
                in_string = None
        elif char in "\"'":
            in_string = char
        elif char == "\\" and text[pos + 1:pos + 3].startswith(("\n", "\r\n")):
            pos += 2 if text[pos + 1] == "\n" else 3
            continue
        elif char == "\n" or text.startswith(("//", "/*"), pos):
            break
        pos += 1
    end = min(pos, len(text))
    while end > start and text[end - 1].isspace():  # rstrip, without copying the file
        end -= 1
    return end


@dataclass
class Event:
    """A unit of the C file: "blank", "comment", "directive", "statement", "control" (an
    if/for/else/label head), "open" or "close" (a brace)."""

    kind: str
    tokens: list[Token]
    line: int
    trailing: list[Token] = field(default_factory=list)  # comments on its line or inside it

    @cached_property
    def end_line(self) -> int:
        """Computed once: the tokens of an event never change, and a run of comments after
        a long statement asks for it once per comment."""
        return max(t.end_line for t in self.tokens) if self.tokens else self.line


def events(text: str) -> list[Event]:
    """Group the tokens into statements, blocks, comments and blank lines."""
    out: list[Event] = []
    pending: list[Token] = []
    inner_comments: list[Token] = []
    depth = 0  # () and [] nesting
    initializer = 0  # braces inside `= { ... }`
    lines_with_tokens: set[int] = set()

    def finish(kind: str = "statement") -> None:
        nonlocal pending, inner_comments
        if pending:
            for part_kind, part in _split_control(pending):
                out.append(Event(part_kind if kind == "statement" else kind, part,
                                 part[0].line))
            out[-1].trailing += inner_comments
        elif inner_comments:
            out.extend(Event("comment", [c], c.line) for c in inner_comments)
        pending, inner_comments = [], []

    for token in tokenize(text):
        for line in range(token.line, token.end_line + 1):
            lines_with_tokens.add(line)
        if token.kind == "comment":
            if pending:
                inner_comments.append(token)
            elif out and out[-1].kind not in ("comment", "blank") and \
                    out[-1].end_line == token.line:
                out[-1].trailing.append(token)
            else:
                out.append(Event("comment", [token], token.line))
            continue
        if token.kind == "directive":
            finish()
            out.append(Event("directive", [token], token.line))
            continue
        text_ = token.text
        if text_ in "([" and token.kind == "punct":
            depth += 1
        elif text_ in ")]" and token.kind == "punct":
            depth = max(0, depth - 1)
        if token.kind == "punct" and depth == 0:
            if text_ == "{":
                if initializer or (pending and pending[-1].text in ("=", ",")):
                    initializer += 1
                    pending.append(token)
                    continue
                finish()
                out.append(Event("open", [token], token.line))
                continue
            if text_ == "}":
                if initializer:
                    initializer -= 1
                    pending.append(token)
                    continue
                finish()
                out.append(Event("close", [token], token.line))
                continue
            if text_ == ";" and not initializer:
                pending.append(token)
                finish()
                continue
        pending.append(token)
    finish()
    return _with_blank_lines(out, text, lines_with_tokens)


def _with_blank_lines(items: list[Event], text: str, used: set[int]) -> list[Event]:
    """Insert one "blank" event for each run of empty lines between events."""
    blank_lines = [False] + [not line.strip() for line in text.split("\n")]
    for number in used:
        if number < len(blank_lines):
            blank_lines[number] = False
    out: list[Event] = []
    last_line = 0
    for event in items:
        if any(blank_lines[last_line + 1:event.line]):
            out.append(Event("blank", [], event.line))
        out.append(event)
        last_line = max([event.end_line, *(c.end_line for c in event.trailing)])
    return out


def _split_control(tokens: list[Token]) -> Iterator[tuple[str, list[Token]]]:
    """Peel `if (...)`, `for (...)`, `else`, `do`, `case x:` and `label:` heads off a
    statement: they are C control flow, the rest is an ordinary statement. Walks the tokens
    once (an index, not shrinking copies: a long run of heads stays linear)."""
    at, count = 0, len(tokens)
    while at < count:
        first = tokens[at]
        following = tokens[at + 1].text if at + 1 < count else None
        if first.kind == "ident" and first.text in CONTROL_WORDS and following == "(":
            end = matching(tokens, at + 1)
            yield "control", tokens[at:end + 1]
            at = end + 1
        elif first.kind == "ident" and first.text in LONE_CONTROL_WORDS:
            yield "control", [first]
            at += 1
        elif first.kind == "ident" and first.text in ("case", "default"):
            end = next((i for i in range(at, count) if tokens[i].text == ":"), count - 1)
            yield "control", tokens[at:end + 1]
            at = end + 1
        elif first.kind == "ident" and following == ":" and first.text not in TYPE_WORDS:
            yield "control", tokens[at:at + 2]
            at += 2
        else:
            yield "statement", tokens[at:]
            return


def matching(tokens: list[Token], open_index: int) -> int:
    """The index of the bracket that closes the one at `open_index` (else the last token)."""
    depth = 0
    for index in range(open_index, len(tokens)):
        if tokens[index].text in "([" and tokens[index].kind == "punct":
            depth += 1
        elif tokens[index].text in ")]" and tokens[index].kind == "punct":
            depth -= 1
            if depth == 0:
                return index
    return len(tokens) - 1


def comment_text(token: Token) -> str:
    return " ".join(line for line in comment_lines(token.text) if line)


def comment_lines(text: str) -> list[str]:
    """The text of a // or /* */ comment, line by line, without its markers."""
    if text.startswith("//"):
        return [text[2:].strip()]
    body = text[2:-2] if text.endswith("*/") else text[2:]
    lines = body.splitlines() or [""]
    out = []
    for index, line in enumerate(lines):
        stripped = line.strip()
        if index > 0 and stripped.startswith("*"):
            stripped = stripped[1:].strip()
        out.append(stripped)
    while len(out) > 1 and not out[-1]:
        out.pop()
    while len(out) > 1 and not out[0]:
        out.pop(0)
    return out
