"""Build-wide names, shared by every program of a build and by the configuration blocks.

`Scope` holds the CONSTs (folded lazily, cycles reported), ALIASes and declared `VAR name`
variables (placed in the variable pool), and says what a name means; the name patterns and
keywords live here because declaring a name is where they are first checked. `temps_for` is
the share of the temporary pool an MP or an ISR computes in.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from mplang.ir.catalogue import Catalogue
from mplang.ir.fold import apply_operator, walk_expr, wrap32
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.limits import MAX_EXPRESSION_DEPTH, expression_depth
from mplang.lang.record import FrozenRecord, Record

if TYPE_CHECKING:
    from mplang.ir.textmemo import TextMemo

VAR_RE = re.compile(r"VAR(\d+)", re.IGNORECASE)
BVAR_RE = re.compile(r"BVAR(\d+)", re.IGNORECASE)
PROGRAM_RE = re.compile(r"(MP|ISR)(\d+)", re.IGNORECASE)
KEYWORDS = {"CONST", "ALIAS", "VAR", "WHILE", "REPEAT", "INCLUDE", "MP", "ISR", "END", "FOR",
            "NEXT", "EXIT", "IF", "THEN", "ELSE", "LABEL", "GOTO", "CALL", "TERMINATE",
            "INIT", "INTERRUPTS", "TRIGGERS", "ON"}


class ConstError(Exception):
    """A constant that cannot be evaluated. code "" marks a follow-on of an error already
    reported (a CONST whose own definition failed), which is not reported again."""

    def __init__(self, span: Span, message: str, code: str = "E206") -> None:
        super().__init__(message)
        self.span = span
        self.message = message
        self.code = code


DEFAULT_VAR_POOL = range(400, 500)
# Expression levels of CONSTs evaluated inside one another (each counts its own depth and
# one for the CONST): folding follows them recursively, so they are bounded like one
# expression, with some room for chains of simple CONSTs written out of order.
MAX_CONST_NESTING = 4 * MAX_EXPRESSION_DEPTH


class Variable(FrozenRecord):
    """A `VAR name` declaration as placed: the host finds it at holding register 300 + 2n."""

    name: str
    index: int
    pinned: bool
    span: Span
    _fields = __match_args__ = ("name", "index", "pinned", "span")

    def __init__(self, name: str, index: int, pinned: bool, span: Span) -> None:
        self.__dict__.update(name=name, index=index, pinned=pinned, span=span)


class Scope(Record):
    """Build-wide names: constants (evaluated lazily, cycles reported), aliases, and the
    declared variables (`VAR name [@ VARn]`), which become aliases once placed."""

    catalogue: Catalogue
    sink: DiagnosticSink
    var_pool: range
    temps: range
    const_exprs: dict[str, ast.Const]
    const_values: dict[str, int | None]
    aliases: dict[str, int]
    alias_spans: dict[str, Span]
    variables: list[Variable]
    alias_names: list[Variable]  # ALIASes, as written
    declared_indices: set[int]
    _evaluating: set[str]
    _nesting: int  # expression levels of the CONSTs being evaluated, one inside another
    _wrapped: set[tuple[str, int, int]]  # W110 said here
    _fields = __match_args__ = ("catalogue", "sink", "var_pool", "temps", "const_exprs",
                                "const_values", "aliases", "alias_spans", "variables",
                                "alias_names", "declared_indices", "_evaluating", "_nesting",
                                "_wrapped")

    def __init__(self, catalogue: Catalogue, sink: DiagnosticSink,
                 var_pool: range = DEFAULT_VAR_POOL, temps: range = range(0),
                 const_exprs: dict[str, ast.Const] | None = None,
                 const_values: dict[str, int | None] | None = None,
                 aliases: dict[str, int] | None = None,
                 alias_spans: dict[str, Span] | None = None,
                 variables: list[Variable] | None = None,
                 alias_names: list[Variable] | None = None,
                 declared_indices: set[int] | None = None, _evaluating: set[str] | None = None,
                 _nesting: int = 0, _wrapped: set[tuple[str, int, int]] | None = None) -> None:
        self.catalogue = catalogue
        self.sink = sink
        self.var_pool = var_pool
        self.temps = temps
        self.const_exprs = {} if const_exprs is None else const_exprs
        self.const_values = {} if const_values is None else const_values
        self.aliases = {} if aliases is None else aliases
        self.alias_spans = {} if alias_spans is None else alias_spans
        self.variables = [] if variables is None else variables
        self.alias_names = [] if alias_names is None else alias_names
        self.declared_indices = set() if declared_indices is None else declared_indices
        self._evaluating = set() if _evaluating is None else _evaluating
        self._nesting = _nesting
        self._wrapped = set() if _wrapped is None else _wrapped
        # the build's statements lowered once per text (`ir.textmemo`), when the
        # compiler gives the sources' lines: not a field (a cache, not a name)
        self.text_memo: TextMemo | None = None

    @classmethod
    def declared(cls, unit: ast.Unit, catalogue: Catalogue, sink: DiagnosticSink,
                 var_pool: range = DEFAULT_VAR_POOL, temps: range = range(0)) -> Scope:
        """The build's names, declared; a constant that cannot be evaluated is reported to
        `sink` (every lowering of a unit starts here)."""
        scope = cls(catalogue, sink, var_pool, temps)
        try:
            scope.declare(unit)
        except ConstError as err:
            if err.code:
                sink.add(err.code, err.span, err.message)
        return scope

    def reserved(self, name: str) -> str | None:
        upper = name.upper()
        profile = self.catalogue.profile
        if upper in KEYWORDS:
            return "a keyword"
        if VAR_RE.fullmatch(upper) or BVAR_RE.fullmatch(upper):
            return "a variable name"
        if PROGRAM_RE.fullmatch(upper):
            return "a program name"
        if profile.axis_code(upper) is not None:
            return "an axis name"
        if self.catalogue.lookup(upper) is not None:
            return "a command name"
        if upper in profile.cmp_symbols:
            return "a comparison constant"
        return None

    def _variable_index(self, text: str, span: Span, what: str) -> int | None:
        """The n of a VARn operand of ALIAS / VAR @, checked (None, reported, if bad)."""
        match = VAR_RE.fullmatch(text)
        if not match:
            self.sink.add("E207", span, f"{what} must name a variable VARn, not {text!r}")
            return None
        index = int(match.group(1))
        if index >= self.catalogue.profile.var("count"):
            last = self.catalogue.profile.var("count") - 1
            self.sink.add("E204", span, f"{text} does not exist: variables are VAR0..VAR{last}")
            return None
        return index

    def declare(self, unit: ast.Unit) -> None:
        seen: dict[str, Span] = {}
        decls: list[ast.Const | ast.Alias | ast.VarDecl] = [*unit.consts, *unit.aliases,
                                                             *unit.variables]
        pinned: dict[int, ast.VarDecl] = {}
        unplaced: list[ast.VarDecl] = []
        for decl in decls:
            key = decl.name.upper()
            why = self.reserved(decl.name)
            if why:
                self.sink.add("E205", decl.name_span, f"{decl.name!r} is {why} and cannot be "
                              "redefined")
                continue
            if key in seen:
                self.sink.add("E203", decl.name_span, f"{decl.name!r} is already defined",
                              related=((seen[key], "first definition"),))
                continue
            seen[key] = decl.name_span
            if isinstance(decl, ast.Const):
                self.const_exprs[key] = decl
            elif isinstance(decl, ast.Alias):
                index = self._variable_index(decl.target, decl.target_span,
                                             f"ALIAS {decl.name}")
                if index is not None:
                    self.aliases[key] = index
                    self.alias_spans[key] = decl.name_span
                    self.alias_names.append(Variable(decl.name, index, True, decl.name_span))
            elif decl.pin is None:
                unplaced.append(decl)
            else:
                assert decl.pin_span is not None
                index = self._variable_index(decl.pin, decl.pin_span, f"VAR {decl.name} @")
                if index is None:
                    continue
                if index in pinned:
                    other = pinned[index]
                    self.sink.add("E209", decl.pin_span, f"VAR {decl.name} and VAR "
                                  f"{other.name} are both pinned to VAR{index}",
                                  related=((other.name_span, f"{other.name} is pinned here"),),
                                  hint="pin each variable to its own VARn, or use ALIAS for a "
                                  "second name of the same variable")
                    self.aliases[key] = index  # no follow-on "unknown name" errors
                    continue
                if index in self.temps:
                    self.sink.add("W104", decl.pin_span, f"VAR{index} is in the pool of "
                                  "expression temporaries: its value changes behind your back",
                                  hint="pin it elsewhere, or move the pool with --temp-vars")
                pinned[index] = decl
                self._place(decl, index, pinned=True)
        if unplaced:
            self._allocate(unit, unplaced)
        for key in self.const_exprs:
            try:
                self.const(key)
            except RecursionError:
                decl = self.const_exprs[key]
                self.const_values[key] = None
                self.sink.add("E107", decl.name_span, f"CONST {decl.name} is nested too "
                              "deeply to compute", hint="split it into several CONSTs")

    def _place(self, decl: ast.VarDecl, index: int, pinned: bool) -> None:
        key = decl.name.upper()
        self.aliases[key] = index
        self.alias_spans[key] = decl.name_span
        self.variables.append(Variable(decl.name, index, pinned, decl.name_span))
        self.declared_indices.add(index)

    def _allocate(self, unit: ast.Unit, unplaced: list[ast.VarDecl]) -> None:
        """Unpinned variables get the lowest free VARn of the pool, in declaration order:
        free means named by nothing in the build (VARn, ALIAS, a pin) and not a temporary."""
        used = set(self.aliases.values()) | _named_variables(unit)
        free = (n for n in self.var_pool if n not in used and n not in self.temps)
        for decl in unplaced:
            index = next(free, None)
            if index is None:
                first, last = self.var_pool.start, self.var_pool.stop - 1
                self.sink.add("E208", decl.name_span, f"no free variable left for VAR "
                              f"{decl.name}: the pool VAR{first}..VAR{last} is used up",
                              hint="widen var-pool in mpc.toml, or pin some variables "
                              "with VAR name @ VARn")
                # the build has failed; naming some VAR avoids "unknown name" follow-ons
                self.aliases[decl.name.upper()] = self.var_pool.start
                continue
            self._place(decl, index, pinned=False)

    def const(self, key: str) -> int | None:
        """Value of a CONST (None if it could not be evaluated; reported once)."""
        if key in self.const_values:
            return self.const_values[key]
        decl = self.const_exprs[key]
        if key in self._evaluating:
            raise ConstError(decl.name_span, f"CONST {decl.name} is defined in terms of itself")
        levels = expression_depth(decl.value) + 1
        if self._nesting + levels > MAX_CONST_NESTING:
            # CONSTs defined through each other, each evaluated inside the next: bounded like
            # one expression, reported once (the CONSTs above it take no value, silently)
            self.sink.add("E107", decl.name_span, f"CONST {decl.name} is reached through "
                          f"CONSTs nested more than {MAX_CONST_NESTING} expression levels "
                          "deep, more than the compiler follows",
                          hint="define the CONSTs in the order they build on each other, or "
                          "write fewer levels")
            self.const_values[key] = None
            return None
        self._nesting += levels
        self._evaluating.add(key)
        try:
            value: int | None = self.fold(decl.value)
            if value is None:
                self._not_constant(decl)
        except ConstError as err:
            if err.code:
                self.sink.add(err.code, err.span, err.message)
            value = None
        finally:
            self._evaluating.discard(key)
            self._nesting -= levels
        self.const_values[key] = value
        return value

    def _not_constant(self, decl: ast.Const) -> None:
        """E206, naming the first name that keeps the value from being a constant."""
        hint = "CONST values may use numbers, other CONSTs and + - * / & | ( )"
        culprit = next((e for e in walk_expr(decl.value) if isinstance(e, ast.Call) or (
            isinstance(e, ast.Name) and e.name.upper() not in self.const_exprs)), None)
        if isinstance(culprit, ast.Call):
            self.sink.add("E206", culprit.span, f"CONST {decl.name} uses {culprit.name}(...), "
                          "which is read at run time, so it is not a constant",
                          hint="assign it to a variable in a program instead")
            return
        if not isinstance(culprit, ast.Name):
            self.sink.add("E206", decl.value.span, f"CONST {decl.name} is not a constant "
                          "expression", hint=hint)
            return
        what = "a variable" if self.variable(culprit.name) is not None else \
            self.reserved(culprit.name) or "not defined"
        self.sink.add("E206", culprit.span, f"CONST {decl.name} uses {culprit.name}, which is "
                      f"{what}, so it is not a constant",
                      hint=did_you_mean(culprit.name, list(self.const_exprs)) or hint)

    def fold(self, expr: ast.Expr) -> int | None:
        """Integer value of a constant expression, None if it involves run-time values."""
        match expr:
            case ast.Num(value=value):
                return value
            case ast.Name(name=name):
                key = name.upper()
                if key in self.const_exprs:
                    known = self.const(key)
                    if known is None:
                        raise ConstError(expr.span, f"CONST {name} has no value", code="")
                    return known
                return None
            case ast.Neg(operand=operand):
                inner = self.fold(operand)
                return None if inner is None else self._wrapping(expr, -inner, f"-({inner})")
            case ast.Group(items=[single]):
                return self.fold(single)
            case ast.BinOp(op=op, left=left, right=right):
                a, b = self.fold(left), self.fold(right)
                if a is None or b is None:
                    return None
                try:
                    exact = apply_operator(op, a, b, wrap=False)
                except ZeroDivisionError:
                    raise ConstError(right.span, "division by zero in a constant "
                                     "expression") from None
                return self._wrapping(expr, exact, f"{a} {op} {b}")
        return None

    def _wrapping(self, expr: ast.Expr, exact: int, shown: str) -> int:
        """`exact` as the device's 32-bit VAR_CALCULATE leaves it, with W110 (once per place)
        when that differs: folding computes exactly what the controller would."""
        wrapped = wrap32(exact)
        if wrapped != exact:
            key = (expr.span.file, expr.span.line, expr.span.col)
            if key not in self._wrapped:
                self._wrapped.add(key)
                self.sink.add("W110", expr.span, f"{shown} = {exact} does not fit in 32 bits; "
                              f"the device wraps it to {wrapped}, and so does the compiler",
                              hint="if the wrap is meant, write the wrapped value; otherwise "
                              "scale the numbers down")
        return wrapped

    def variable(self, name: str) -> int | None:
        """Index of VARn or of an alias, None if the name is not a variable."""
        key = name.upper()
        if key in self.aliases:
            return self.aliases[key]
        match = VAR_RE.fullmatch(key)
        return int(match.group(1)) if match else None


def _named_variables(unit: ast.Unit) -> set[int]:
    """Every VARn written literally anywhere in the programs of the build."""
    found: set[int] = set()
    for program in unit.programs:
        _collect_named(program.body, found)
    return found


def _collect_named(node: object, found: set[int]) -> None:
    """Add to `found` every VARn that `node` (a syntax node or a list of them) names, at any
    depth: read in an expression or written by an assignment."""
    if isinstance(node, list):
        for item in node:
            _collect_named(item, found)
        return
    if isinstance(node, ast.Name):
        match = VAR_RE.fullmatch(node.name)
    elif isinstance(node, ast.Assign):
        match = VAR_RE.fullmatch(node.target)
    else:
        match = None
    if match:
        found.add(int(match.group(1)))
    for name in getattr(node, "_fields", ()):
        value = getattr(node, name)
        if isinstance(value, list) or hasattr(value, "_fields"):
            _collect_named(value, found)


def did_you_mean(name: str, candidates: list[str]) -> str:
    """A hint for a misspelt name; difflib is imported here, by the first build that has
    one, not by every start-up."""
    import difflib

    close = difflib.get_close_matches(name.upper(), candidates, n=1, cutoff=0.6)
    return f"did you mean {close[0]}?" if close else ""


def temps_for(kind: str, temps: range) -> range:
    """The part of the temporary pool a program of `kind` computes in. An ISR runs between
    two lines of the MP it interrupts, so it must not overwrite the MP's half-computed
    temporaries: ISRs take the top quarter of the pool (at least two variables), MPs the
    rest. A pool of fewer than four variables is shared (and then an ISR must not compute
    expressions while an MP may be interrupted in one)."""
    if len(temps) < 4:
        return temps
    isr_count = max(2, len(temps) // 4)
    split = temps.stop - isr_count
    return range(split, temps.stop) if kind == "isr" else range(temps.start, split)
