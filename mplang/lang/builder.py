"""The syntax tree's builder: one method per grammar rule, from tokens to AST nodes.

Lark calls these methods while it parses (`mplang.lang.parser._Builder` hands them to it);
a line replayed from a recorded parse (`mplang.lang.recipes`) calls the very same methods
with tokens of its own. So this module imports nothing of lark: a build whose only new lines
differ from known ones in their numbers never loads it. A token is anything that is a `str`
with lark's `type`, `line` and `column` (lark's `Token`, or a `Lexeme`); no node a rule
builds is a string, so `isinstance(item, _TOKEN)` tells a token from a built node.
"""

from __future__ import annotations

from typing import Any

from mplang.lang import ast
from mplang.lang.diagnostics import Span, make_span
from mplang.lang.limits import number_too_long


class Lexeme(str):
    """A token made without lark: its text, its terminal's name and where it starts (the
    attributes of lark's `Token` the builder reads)."""

    type: str
    line: int | None
    column: int | None


def lexeme(text: str, terminal: str, line: int, column: int) -> Lexeme:
    """A `Lexeme` of `text`, terminal `terminal`, at `line`:`column` (1-based)."""
    made = Lexeme(text)
    made.type = terminal
    made.line = line
    made.column = column
    return made


class SyntaxProblem(Exception):
    """Raised inside the transformer for lexically valid but malformed constructs."""

    def __init__(self, token: Lexeme, message: str, code: str = "E101",
                 hint: str = "write NAME(a, b) or NAME a, b") -> None:
        super().__init__(message)
        self.token = token
        self.message = message
        self.code = code
        self.hint = hint


def int_value(token: Lexeme) -> int:
    """INT is hex (0x1F) or decimal; leading zeros are decimal (int(.., 0) refuses them).
    A literal longer than any device value is refused (E108) before it is converted."""
    text = str(token)
    problem = number_too_long(text)
    if problem is not None:
        raise SyntaxProblem(token, problem, code="E108",
                            hint="write the value the device should hold (32-bit)")
    return int(text, 16) if text[:2].lower() == "0x" else int(text, 10)


_TOKEN: type[Lexeme] = str  # type: ignore[assignment]
"""What a token is an instance of: lark's `Token` and `Lexeme` are both strings, and
nothing else a rule receives is one (for the type checker, a `Lexeme`)."""

_PRECEDENCE = {"|": 1, "&": 2, "+": 3, "-": 3, "*": 4, "/": 4}


def _combine(operators: list[str], operands: list[ast.Expr]) -> None:
    """Replace the last two operands by the last operator applied to them."""
    right = operands.pop()
    left = operands.pop()
    operands.append(ast.BinOp(operators.pop(), left, right, left.span))


class Rules:
    """Builds AST nodes straight from tokens (no intermediate tree, no position propagation).
    Each rule's method takes the rule's children as arguments (None for an absent optional
    part); `file` and `line_offset` say where the tokens' lines are."""

    def __init__(self, file: str, line_offset: int = 0) -> None:
        self.file = file
        self.line_offset = line_offset

    def _span(self, token: Lexeme) -> Span:
        line = (token.line or 1) + self.line_offset
        col = token.column or 1
        return make_span(self.file, line, col, col + len(token))  # a token is its text

    def _first_span(self, *items: Any) -> Span:
        for item in items:
            if isinstance(item, _TOKEN):
                return self._span(item)
            span = getattr(item, "span", None)
            if isinstance(span, Span):
                return span
        return Span(self.file, 1 + self.line_offset)

    # -------------------------------------------------------------- expressions
    def number(self, tok: Lexeme) -> ast.Num:
        return ast.Num(int_value(tok), self._span(tok))

    def _operand(self, item: Any) -> ast.Expr:
        if not isinstance(item, _TOKEN):
            return item  # type: ignore[no-any-return]  # a number, call or group, built already
        if item.type == "NAME":
            return ast.Name(str(item), self._span(item))
        return ast.Str(str(item)[1:-1], self._span(item))

    def expr(self, *items: Any) -> ast.Expr:
        """Operands with their signs and operators, flat: the tree by precedence climbing
        (`|` < `&` < `+ -` < `* /`, left-associative); a sign binds tighter, and a minus
        before a number folds into it."""
        operands: list[ast.Expr] = []
        operators: list[str] = []
        index, count = 0, len(items)
        while index < count:
            signs: list[Lexeme] = []
            item = items[index]
            while isinstance(item, _TOKEN) and (item.type == "MINUS" or item.type == "PLUS"):
                signs.append(item)
                index += 1
                item = items[index]
            operand = self._operand(item)
            for sign in reversed(signs):
                if sign.type == "MINUS":
                    operand = ast.Num(-operand.value, self._span(sign)) \
                        if isinstance(operand, ast.Num) else ast.Neg(operand, self._span(sign))
            operands.append(operand)
            index += 1
            if index < count:  # an operator: first combine what binds at least as tightly
                operator = str(items[index])
                index += 1
                precedence = _PRECEDENCE[operator]
                while operators and _PRECEDENCE[operators[-1]] >= precedence:
                    _combine(operators, operands)
                operators.append(operator)
        while operators:
            _combine(operators, operands)
        return operands[0]

    def call(self, name: Lexeme, lpar: Lexeme, *rest: Any) -> ast.Call:
        args = [a for a in rest if a is not None and not isinstance(a, _TOKEN)]
        return ast.Call(str(name), args, self._span(name))

    def group(self, lpar: Lexeme, *rest: Any) -> ast.Group:
        items = [a for a in rest if a is not None and not isinstance(a, _TOKEN)]
        return ast.Group(items, self._span(lpar))

    # --------------------------------------------------------------- statements
    def const_decl(self, kw: Lexeme, name: Lexeme, value: ast.Expr) -> ast.Const:
        return ast.Const(str(name), value, self._span(kw), self._span(name))

    def alias_decl(self, kw: Lexeme, name: Lexeme, target: Lexeme) -> ast.Alias:
        return ast.Alias(str(name), str(target), self._span(kw), self._span(name),
                         self._span(target))

    def var_decl(self, kw: Lexeme, name: Lexeme, _at: Lexeme | None, pin: Lexeme | None
                 ) -> ast.VarDecl:
        return ast.VarDecl(str(name), str(pin) if pin else None, self._span(kw),
                           self._span(name), self._span(pin) if pin else None)

    def include(self, kw: Lexeme, path: Lexeme) -> ast.Include:
        return ast.Include(str(path)[1:-1], self._span(kw))

    def program_header(self, kw: Lexeme, number: Lexeme | None, name: Lexeme | None
                       ) -> ast.ProgramHeader:
        return ast.ProgramHeader(str(kw.type).lower(), int_value(number) if number else None,
                                 str(name) if name else None, self._span(kw))

    def end_stmt(self, kw: Lexeme, what: Lexeme) -> ast.End:
        return ast.End(str(what.type).lower(), self._span(kw))

    def for_stmt(self, kw: Lexeme, count: ast.Expr) -> ast.ForStmt:
        return ast.ForStmt(count, self._span(kw))

    def while_stmt(self, kw: Lexeme, left: ast.Expr, op: Lexeme, right: ast.Expr
                   ) -> ast.WhileStmt:
        return ast.WhileStmt(left, str(op), right, self._span(kw))

    def repeat_stmt(self, kw: Lexeme, count: ast.Expr) -> ast.RepeatStmt:
        return ast.RepeatStmt(count, self._span(kw))

    def next_stmt(self, kw: Lexeme) -> ast.Next:
        return ast.Next(self._span(kw))

    def exit_stmt(self, kw: Lexeme, loop: Lexeme | None) -> ast.Exit | ast.ExitFor:
        return ast.ExitFor(self._span(kw)) if loop else ast.Exit(self._span(kw))

    def if_stmt(self, kw: Lexeme, left: ast.Expr, op: Lexeme, right: ast.Expr,
                then: Lexeme | None) -> ast.IfStmt:
        return ast.IfStmt(left, str(op), right, self._span(kw))

    def else_stmt(self, kw: Lexeme) -> ast.Else:
        return ast.Else(self._span(kw))

    def label_stmt(self, kw: Lexeme, label: Lexeme) -> ast.LabelStmt:
        return ast.LabelStmt(str(label), self._span(kw))

    def goto_stmt(self, kw: Lexeme, label: Lexeme) -> ast.Goto:
        return ast.Goto(str(label), self._span(kw), self._span(label))

    def call_stmt(self, kw: Lexeme, target: Lexeme) -> ast.CallStmt:
        return ast.CallStmt(str(target), self._span(kw), self._span(target))

    def terminate_stmt(self, kw: Lexeme) -> ast.Terminate:
        return ast.Terminate(self._span(kw))

    def assign(self, target: Lexeme, value: ast.Expr) -> ast.Assign:
        return ast.Assign(str(target), self._span(target), value, self._span(target))

    def command(self, name: Lexeme, *args: ast.Expr | None) -> ast.Command:
        items = [a for a in args if a is not None]
        # `NAME(a, b)` arrives as one parenthesised group: it is the argument list.
        if len(items) == 1 and isinstance(items[0], ast.Group):
            items = list(items[0].items)
        for item in items:
            if isinstance(item, ast.Group) and len(item.items) != 1:
                raise SyntaxProblem(name, "a parenthesised list can only be the whole "
                                    "argument list")
        return ast.Command(str(name), items, self._span(name), self._span(name))

    def init_header(self, kw: Lexeme) -> ast.InitHeader:
        return ast.InitHeader(self._span(kw))

    def interrupts_header(self, kw: Lexeme, mp: Lexeme | None, target: Lexeme
                          ) -> ast.InterruptsHeader:
        text = f"MP{target}" if mp is not None else str(target)
        return ast.InterruptsHeader(text, self._span(kw), self._span(mp or target))

    def triggers_header(self, kw: Lexeme) -> ast.TriggersHeader:
        return ast.TriggersHeader(self._span(kw))

    def on_stmt(self, kw: Lexeme, subject: Lexeme, condition: Lexeme,
                action: tuple[str, str | None, str | None, Span]) -> ast.OnStmt:
        word, argument, kind, span = action
        text = str(subject)
        if subject.type == "DI_PIN":
            text = "DI " + text[2:].strip()
        return ast.OnStmt(text, self._span(subject), str(condition), self._span(condition),
                          word, argument, kind, span, self._span(kw))

    def on_call(self, kw: Lexeme, kind: Lexeme | None, target: Lexeme
                ) -> tuple[str, str | None, str | None, Span]:
        return ("CALL", str(target), str(kind.type).lower() if kind else None,
                self._span(target))

    def on_words(self, first: Lexeme, second: Lexeme | None
                 ) -> tuple[str, str | None, str | None, Span]:
        return (str(first).upper(), str(second) if second else None, None, self._span(first))

    def start(self, *statements: Any) -> list[ast.Statement]:
        return [s for s in statements if s is not None]

    def line(self, statement: Any = None) -> list[ast.Statement]:
        return [] if statement is None else [statement]
