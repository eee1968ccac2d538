"""One source line as words, for the editor features.

The grammar is one statement per line, so what the cursor is on (a command, a label after
GOTO, the third argument of a call, ...) can be read off its own line. Reading the line again
here, instead of asking the parser, keeps hover and completion working on lines the parser
rejects, including the half-typed line under the cursor.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property

# The grammar's terminals, in the order its lexer tries them (grammar/mplang.lark). An
# unterminated string runs to the end of the line, as it does while being typed.
_TOKEN = re.compile(
    r"""(?P<comment>\#.*|//.*)
      | (?P<string>"[^"\n]*"?|'[^'\n]*'?)
      | (?P<int>0[xX][0-9a-fA-F]+|[0-9]+)
      | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
      | (?P<op><=|>=|==|!=|[-+*/&|(),=<>@])
      | (?P<other>\S)""",
    re.VERBOSE,
)


@dataclass(frozen=True)
class Token:
    kind: str  # name, int, string, op, comment, other
    text: str
    start: int  # 0-based code point columns, end exclusive
    end: int

    @property
    def upper(self) -> str:
        return self.text.upper()

    @property
    def string_value(self) -> str:
        """The text between the quotes of a string token (closed or not)."""
        body = self.text[1:]
        return body[:-1] if len(body) and body[-1] == self.text[0] else body


_KEPT_LINES = 32_768
"""How many line texts keep their tokens (a whole device has about 6,000 distinct lines)."""
_lexed: dict[str, list[Token]] = {}


def lex_line(text: str) -> list[Token]:
    """A line's tokens, kept by its text: every check indexes the definitions and headers
    of every file, and the semantic tokens read every line, nearly all as they were. The
    list is shared between callers: never changed by one."""
    found = _lexed.get(text)
    if found is None:
        if len(_lexed) >= _KEPT_LINES:
            _lexed.clear()
        found = _lexed[text] = [
            Token(match.lastgroup or "other", match.group(), match.start(), match.end())
            for match in _TOKEN.finditer(text)]
    return found


def word_at(tokens: list[Token], character: int) -> Token | None:
    """The name, number or string the cursor is on or just after."""
    for token in tokens:
        if token.kind in ("name", "int", "string") and token.start <= character <= token.end:
            return token
    return None


@dataclass(frozen=True)
class ArgumentSlot:
    """The cursor stands in argument `index` (0-based) of the command or call `command`."""

    command: str
    index: int


@dataclass(frozen=True)
class Cursor:
    """What surrounds a cursor on its line."""

    tokens: list[Token]
    before: list[Token]  # code tokens that end before the word being typed
    word: Token | None  # the name or number being typed or pointed at
    in_comment: bool
    string: Token | None  # the string the cursor is inside, if any

    @cached_property
    def head(self) -> str:
        """The statement's first word, upper case ('' if none); kept, as semantic tokens ask
        it of every word of a line."""
        code = [t for t in self.tokens if t.kind != "comment"]
        return code[0].upper if code and code[0].kind == "name" else ""

    @property
    def position(self) -> int:
        """Index of the word being typed among the line's code tokens."""
        return len(self.before)

    def argument(self) -> ArgumentSlot | None:
        return argument_slot(self.before)

    def after_equals(self) -> bool:
        """The cursor is in the value of `target = ...` or of `CONST NAME = ...`."""
        return any(t.text == "=" for t in self.before)


def cursor_at(text: str, character: int) -> Cursor:
    tokens = lex_line(text)
    code = [t for t in tokens if t.kind != "comment"]
    in_comment = any(t.kind == "comment" and t.start < character for t in tokens)
    string = next((t for t in code if t.kind == "string" and t.start < character and
                   (character < t.end or t.string_value == t.text[1:])), None)
    word = word_at(code, character)
    if word is not None and word.kind == "string":
        word = None
    limit = word.start if word is not None else character
    before = [t for t in code if t.end <= limit]
    return Cursor(tokens, before, word, in_comment, string)


# Words of one line read in their place in the statement; past these (only a long expression
# has more) a word is read alone, so that a hostile line of a million words costs linear time.
WORDS_IN_PLACE = 64


def line_words(text: str) -> list[tuple[Token, Cursor]]:
    """Every name and number of a line, each with the cursor that stands on it (as
    `cursor_at(text, word.start)` gives it, for the first WORDS_IN_PLACE words; after them a
    cursor that sees the word alone). A word glued to the one before it (`12ab`) is skipped:
    a cursor there stands on the earlier word."""
    tokens = lex_line(text)
    code = [t for t in tokens if t.kind != "comment"]
    found: list[tuple[Token, Cursor]] = []
    for index, token in enumerate(code):
        if token.kind not in ("name", "int"):
            continue
        previous = code[index - 1] if index else None
        if previous is not None and previous.end == token.start and \
                previous.kind in ("name", "int", "string"):
            continue
        if len(found) < WORDS_IN_PLACE:
            found.append((token, Cursor(tokens, code[:index], token, False, None)))
        else:
            found.append((token, Cursor([token], [], token, False, None)))
    return found


def argument_slot(before: list[Token]) -> ArgumentSlot | None:
    """Which argument of which command the tokens before the cursor leave it in.

    `FIXED_MOVE X, |` is argument 1 of FIXED_MOVE; `VAR1 = GET_LP(|` argument 0 of GET_LP;
    keyword statements (IF, FOR, ...) and assignments outside a call have none.
    """
    from mplang.ir.lower import KEYWORDS

    open_calls: list[tuple[str | None, int]] = []
    statement_commas = 0
    for index, token in enumerate(before):
        if token.text == "(":
            previous = before[index - 1] if index else None
            named = previous is not None and previous.kind == "name" and \
                previous.upper not in KEYWORDS
            open_calls.append((previous.text if named and previous else None, 0))
        elif token.text == ")" and open_calls:
            open_calls.pop()
        elif token.text == ",":
            if open_calls:
                name, commas = open_calls[-1]
                open_calls[-1] = (name, commas + 1)
            else:
                statement_commas += 1
    for name, commas in reversed(open_calls):
        if name is not None:
            return ArgumentSlot(name, commas)
    if not before or before[0].kind != "name" or before[0].upper in KEYWORDS:
        return None
    if len(before) > 1 and before[1].text == "=":
        return None
    return ArgumentSlot(before[0].text, statement_commas)
