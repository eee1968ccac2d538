"""AST -> macro lines, with the checks that need names, types and block context.

One `ProgramLowerer` walks one program. Names are resolved against the build's CONSTs and
ALIASes, command arguments are checked against the catalogue's parameter descriptions, and
expressions are lowered through a pool of compiler temporaries into SET_VAR/VAR_CALCULATE
lines. Every problem is reported with its code and the walk goes on.

This module holds the statements and blocks (labels, loops, IF, CALL, ON); the build's names
are in `scope`, the device arithmetic in `fold`, expressions and command arguments in
`operands`, interrupt wiring in `interrupts`. The names other code imports from here are
re-exported (`__all__`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from mplang.ir.blockmemo import CHUNK, Statements, label_statements
from mplang.ir.fold import apply_operator, wrap32
from mplang.ir.interrupts import wire_lines, wires
from mplang.ir.macro import CallSite, LoweredProgram, ProgramRef, VarRef
from mplang.ir.operands import OperandLowerer
from mplang.ir.scope import (
    BVAR_RE,
    DEFAULT_VAR_POOL,
    KEYWORDS,
    PROGRAM_RE,
    VAR_RE,
    ConstError,
    Scope,
    Variable,
    did_you_mean,
    temps_for,
)
from mplang.lang import ast
from mplang.lang.diagnostics import Span
from mplang.lang.record import Record

if TYPE_CHECKING:
    from mplang.ir.textmemo import Recording, TextMemo

__all__ = [
    "BVAR_RE",
    "CONTROL_COMMANDS",
    "DEFAULT_VAR_POOL",
    "KEYWORDS",
    "PROGRAM_RE",
    "VAR_RE",
    "ConstError",
    "ProgramLowerer",
    "Scope",
    "Variable",
    "apply_operator",
    "did_you_mean",
    "temps_for",
    "wrap32",
]

CONTROL_COMMANDS = {"SET_VAR", "VAR_CALCULATE"}


class _Block(Record):
    kind: str  # "for" | "if" | "while" (lowered to an IF)
    emitted: bool  # its opening line was emitted (False after a reported error)
    _fields = __match_args__ = ("kind", "emitted")

    def __init__(self, kind: str, emitted: bool = True) -> None:
        self.kind = kind
        self.emitted = emitted


class ProgramLowerer(OperandLowerer):
    """Lowers one program; label, temporary and block state are per program."""

    def __init__(self, scope: Scope, program: ast.Program, temps: range, target: str,
                 program_names: dict[str, ast.Program]) -> None:
        super().__init__(scope, program, temps, target, program_names)
        self.blocks: list[_Block] = []
        self.labels: dict[str, int] = {}
        self.spare_labels: list[int] = []  # label numbers no LABEL of the source takes
        self.if_depth = self.profile.limit("if_depth")
        self.for_depth = self.profile.limit("for_depth")

    # ---------------------------------------------------------------- statements
    def lower_program(self, kept: Statements | None = None) -> LoweredProgram:
        """The program's macro lines; `kept`, its statements as last lowered, gives each
        unchanged top-level statement its lowering from then (`mplang.ir.blockmemo`)."""
        self.collect_labels(self.program.body, kept)
        if kept is not None:
            kept.start(self)
            self.lower_kept(self.program.body, kept)
            kept.finish()
        elif self.scope.text_memo is not None:  # one build's repeated statements
            self.lower_texts(self.program.body, self.scope.text_memo)
        else:
            self.lower_block(self.program.body)
        return self.out

    def lower_block(self, body: list[ast.Node],
                    step: Callable[[ast.Node], bool] | None = None) -> None:
        """Lower a body; `step`, for a program's body, lowers each of its top-level
        statements through a table of kept ones (`mplang.ir.blockmemo`, `textmemo`)."""
        lower = self.lower_statement if step is None else step
        dead_after: Span | None = None  # set after a jump, until a LABEL makes code live
        warned = False
        for node in body:
            if isinstance(node, ast.LabelStmt):
                dead_after, warned = None, False
            elif dead_after is not None and not warned:
                self.unreachable(node, dead_after)
                warned = True
            jumps = lower(node)
            if jumps and dead_after is None:
                dead_after = node.span

    def lower_kept(self, body: list[ast.Node], kept: Statements) -> None:
        """`lower_block` for a program's body with its statements as last lowered: a chunk
        of them that fits is replayed whole (`blockmemo.Chunk`: only its last statement
        may jump, so no W101 falls inside it), the others go one by one. Its own loop: the
        chunks' skipping would slow the loop every other body is lowered by."""
        dead_after: Span | None = None
        warned = False
        index, count = 0, len(body)
        while index < count:
            node = body[index]
            if dead_after is None:
                chunk = kept.replay_chunk(body, index, self)
                if chunk is not None:
                    index += len(chunk.nodes)
                    if chunk.jumps:
                        dead_after = chunk.nodes[-1].span
                    continue
            index += 1
            dead_after, warned = self.reach(node, dead_after, warned)
            if kept.lower(node, self, self.lower_statement) and dead_after is None:
                dead_after = node.span

    def lower_texts(self, body: list[ast.Node], memo: TextMemo) -> None:
        """`lower_block` for a program's body through the build's `TextMemo`: from every
        CHUNK-th top-level statement where no jump precedes it, a chunk lowered before from
        the same texts is replayed whole, else its statements go one by one (each replayed
        by its own text where it can) and are kept as a chunk. Its own loop, as
        `lower_kept`."""
        context = (self.kind, tuple(self.labels.items()))
        dead_after: Span | None = None
        warned = False
        recording: Recording | None = None
        index, count = 0, len(body)
        while index < count:
            node = body[index]
            if index % CHUNK == 0:
                if recording is not None:
                    memo.keep_chunk(recording, self)
                    recording = None
                if dead_after is None:
                    chunk, recording = memo.chunk(body, index, self, context)
                    if chunk is not None:
                        index += len(chunk.statements)
                        if chunk.jumps:
                            dead_after = body[index - 1].span
                        continue
            index += 1
            dead_after, warned = self.reach(node, dead_after, warned)
            jumps = memo.lower(node, self, context, self.lower_statement)
            if recording is not None and not recording.add(memo.last, jumps):
                recording = None
            if jumps and dead_after is None:
                dead_after = node.span
        if recording is not None:
            memo.keep_chunk(recording, self)

    def reach(self, node: ast.Node, dead_after: Span | None, warned: bool
              ) -> tuple[Span | None, bool]:
        """The W101 state (the jump code is dead after, whether W101 was given since) as
        `node` is reached, W101 given if it is the first statement after the jump."""
        if isinstance(node, ast.LabelStmt):
            return None, False
        if dead_after is not None and not warned:
            self.unreachable(node, dead_after)
            return dead_after, True
        return dead_after, warned

    def unreachable(self, node: ast.Node, dead_after: Span) -> None:
        """W101 of the first statement after a jump."""
        self.sink.add("W101", node.span, f"unreachable: line {dead_after.line} always jumps "
                      "away", hint="remove it, or put a LABEL before it")

    def lower_statement(self, node: ast.Node) -> bool:
        """`lower_node`, with a pathological expression reported instead of a crash."""
        try:
            return self.lower_node(node)
        except RecursionError:
            self.sink.add("E107", node.span, "the statement's expression is nested too "
                          "deeply to compile", hint="split it into several assignments")
            return False

    def lower_node(self, node: ast.Node) -> bool:
        """Lower one node; True if control never falls through it."""
        match node:
            case ast.ForBlock():
                self.lower_for(node)
            case ast.IfBlock():
                self.lower_if(node)
            case ast.WhileBlock():
                self.lower_while(node)
            case ast.RepeatBlock():
                self.lower_repeat(node)
            case ast.Assign():
                self.lower_assign(node)
            case ast.Command():
                self.lower_command(node)
            case ast.LabelStmt():
                self.lower_label(node)
            case ast.Goto():
                self.lower_goto(node)
                return True
            case ast.CallStmt():
                self.lower_call(node)
            case ast.ExitFor():
                loop = next((b for b in reversed(self.blocks) if b.kind == "for"), None)
                if loop is None:
                    self.sink.add("E306", node.span, "EXIT FOR outside a FOR loop",
                                  hint="EXIT leaves the whole program")
                elif loop.emitted:  # a refused FOR (reported) leaves nothing to exit
                    self.emit("EXIT_FOR", (), node.span)
                return True
            case ast.Exit():
                self.emit("EXIT_MACRO", (), node.span)
                return True
            case ast.Terminate():
                self.emit("MP_TERMINATE", (), node.span)
                return True
            case ast.OnStmt():
                self.lower_on(node)
        return False

    def lower_on(self, node: ast.OnStmt) -> None:
        """`ON X P>=C+ CALL ISR 2` inside a program: INTFACTOR_ENABLE per axis (an ISR
        re-arming the next compare, as in the 7.3.12 example)."""
        command = self.cat.macro("INTFACTOR_ENABLE")
        if not self.command_allowed(command, node.span):
            return
        self.out.lines.extend(wire_lines(wires(node, self.cat, self.sink, self.program_names),
                                         self.cat))

    def lower_for(self, node: ast.ForBlock, counter: VarRef | None = None) -> None:
        """FOR count ... NEXT; `counter`: a temporary already holding the count (REPEAT)."""
        if self.kind == "isr":
            self.sink.add("E313", node.span, "FOR loops are not allowed in an ISR")
            self.lower_block(node.body)
            return
        depth = sum(1 for b in self.blocks if b.kind == "for") + 1
        if depth == self.for_depth + 1:  # once, where the nesting passes it
            self.sink.add("E311", node.span, f"FOR nested {depth} deep; the device allows "
                          f"{self.profile.limit('for_depth')} (one outer and "
                          f"{self.profile.limit('for_depth') - 1} inner)")
        try:
            folded = self.fold(node.count)
        except ConstError:
            folded = None
        if folded is not None and folded <= 0:
            self.sink.add("W102", node.count.span, f"FOR {folded} never runs its body")
        count = self.value_operand(node.count) if counter is None else counter
        if isinstance(count, VarRef):
            self.note_write(count)  # the device counts the variable down to zero
        if count is not None:
            self.emit("FOR", (count,), node.span)
        self.blocks.append(_Block("for", emitted=count is not None))
        self.lower_block(node.body)
        self.blocks.pop()
        if count is not None:  # NEXT only with its FOR (see lower_if)
            self.emit("NEXT", (), node.end_span)
        if isinstance(count, VarRef):
            self.give_temp(count)

    def lower_if(self, node: ast.IfBlock, body: list[ast.Node] | None = None,
                 loop_label: int | None = None) -> None:
        """IF ... [ELSE ...] END_IF; for a WHILE (`loop_label`), `body` then GOTO back."""
        depth = sum(1 for b in self.blocks if b.kind != "for") + 1  # IFs and WHILEs
        if depth == self.if_depth + 1:  # once, where the nesting passes it
            self.sink.add("E310", node.span, f"IF nested {depth} deep; the device allows "
                          f"{self.profile.limit('if_depth')} (one outer and "
                          f"{self.profile.limit('if_depth') - 1} inner)")
        op = self.comparison(node.op)
        if op is None:
            self.sink.add("E424", node.span, f"{node.op!r} is not an IF comparison",
                          hint="comparisons: " + " ".join(self.profile.cmp_ops))
        left = self.value_operand(node.left)
        right = self.value_operand(node.right)
        # ELSE and END_IF only with their IF: a refused IF is one error, and no back end
        # meets an END_IF without its IF.
        emitted = left is not None and right is not None and op is not None
        if left is not None and right is not None and op is not None:
            self.emit("IF", (left, self.profile.cmp_ops[op], right), node.span)
        for used in (left, right):
            if isinstance(used, VarRef):
                self.give_temp(used)
        if loop_label is not None:
            self.blocks.append(_Block("while"))
            self.lower_block(body or [])
            self.blocks.pop()
            self.emit("GOTO", (loop_label,), node.end_span)
            if emitted:
                self.emit("END_IF", (), node.end_span)
            return
        self.blocks.append(_Block("if"))
        self.lower_block(node.then)
        if node.otherwise is not None:
            assert node.else_span is not None
            if emitted:
                self.emit("ELSE", (), node.else_span)
            self.lower_block(node.otherwise)
        self.blocks.pop()
        if emitted:
            self.emit("END_IF", (), node.end_span)

    def comparison(self, text: str) -> str | None:
        """The comparison a (raw) IF names: a symbol ("<="), a comparison constant (LE), or
        an operator code, given as a number or a CONST; None if it names none."""
        ops = self.profile.cmp_ops
        if text in ops:
            return text
        key = text.upper()
        if key in self.profile.cmp_symbols:
            return self.profile.cmp_symbols[key]
        code: int | None = None
        if key in self.scope.const_exprs:
            code = self.scope.const(key)
        elif text.lstrip("-")[:2] == "0x":
            code = int(text, 16)
        return next((symbol for symbol, value in ops.items() if value == code), None)

    def lower_while(self, node: ast.WhileBlock) -> None:
        """LABEL top / IF cond / body / GOTO top / END_IF: the condition is computed after
        the label, so every round tests it afresh; one label, no counter."""
        problem = None
        if self.kind == "isr":
            problem = "an ISR has no labels, and a WHILE loop needs one"
        elif self.blocks:
            inner = self.blocks[-1].kind.upper()
            problem = (f"WHILE inside {'an' if inner == 'IF' else 'a'} {inner} block: its "
                       "LABEL would stand inside a block, which the device refuses")
        elif not self.spare_labels:
            self.sink.add("E329", node.span, f"WHILE needs one of the program's "
                          f"{self.profile.limit('labels_per_program')} labels, and they are "
                          "all taken", hint="free a LABEL, or move the loop into a program "
                          "of its own and CALL it")
            self.lower_block(node.body)
            return
        if problem is not None:
            self.sink.add("E328", node.span, problem, hint="move the loop to the top level of "
                          "an MP (a called MP of its own works inside any block), or use FOR "
                          "with EXIT FOR")
            self.lower_block(node.body)
            return
        label = self.spare_labels.pop(0)
        self.emit("LABEL", (label,), node.span)
        self.lower_if(ast.IfBlock(node.left, node.op, node.right, [], None, node.span, None,
                                  node.end_span), body=node.body, loop_label=label)

    def lower_repeat(self, node: ast.RepeatBlock) -> None:
        """A FOR; a count that is a variable of the user's is copied first, because the
        device counts FOR's variable down to zero."""
        copy: VarRef | None = None
        if isinstance(node.count, ast.Name) and self.kind == "mp" and \
                self.scope.variable(node.count.name) is not None:
            copy = self.take_temp(node.span)
            if copy is not None:
                self.lower_into(node.count, copy)
        self.lower_for(ast.ForBlock(node.count, node.body, node.span, node.end_span),
                       counter=copy)

    def lower_assign(self, node: ast.Assign) -> None:
        index = self.scope.variable(node.target)
        if index is None:
            hint = did_you_mean(node.target, list(self.scope.aliases)) or (
                f"declare it with `VAR {node.target}` (a variable the host can read too), or "
                "assign to VARn or to an ALIAS of one")
            self.sink.add("E423", node.target_span, f"cannot assign to {node.target!r}: not a "
                          "variable", hint=hint)
            return
        if not self.check_user_var(index, node.target_span):
            return
        self.lower_into(node.value, VarRef(index))

    def lower_command(self, node: ast.Command) -> None:
        command = self.cat.lookup(node.name)
        if command is None:
            self.unknown_command(node.name, node.name_span)
            return
        if not self.command_allowed(command, node.name_span):
            return
        operands = self.arguments(command, node.args, node.span)
        if operands is None:
            return
        if command.short_name == "SET_RVAR" and not (self.last_command and
                                                      self.last_command.returns):
            self.sink.add("W106", node.span, "SET_RVAR without a value-returning read right "
                          "before it", hint="write VARn = GET_LP(X) instead")
        self.emit_command(command, operands, node.span)

    def collect_labels(self, body: list[ast.Node], kept: Statements | None = None) -> None:
        """Number the program's labels: numeric ones keep their number, names take the lowest
        free numbers in order of definition. `kept`, the program's statements as last
        lowered, gives those of its chunks that are unchanged (`Statements.find_labels`)."""
        defined: dict[str, Span] = {}
        found: list[ast.LabelStmt] = []
        if kept is None:
            label_statements(body, found)
        else:
            kept.find_labels(body, found)
        for node in found:
            key = node.label.upper()
            if key in defined:
                self.sink.add("E322", node.span, f"label {node.label} is defined twice",
                              related=((defined[key], "first definition"),))
                continue
            defined[key] = node.span
            if key.isdigit():
                number = int(key)
                if number > self.profile.limit("label_max"):
                    self.sink.add("E326", node.span, f"label {number} does not exist: labels "
                                  f"are 0..{self.profile.limit('label_max')}")
                    continue
                self.labels[key] = number
        free = [n for n in range(self.profile.limit("labels_per_program"))
                if n not in self.labels.values()]
        self.spare_labels = free  # what named labels leave is for WHILE loops
        for key, span in defined.items():
            if key.isdigit():
                continue
            if not free:
                self.sink.add("E321", span, f"more than {self.profile.limit('labels_per_program')}"
                              " labels in one program", hint="split the program, or reuse "
                              "labels")
                continue
            self.labels[key] = free.pop(0)

    def lower_label(self, node: ast.LabelStmt) -> None:
        if self.kind == "isr":
            self.sink.add("E327", node.span, "LABEL cannot be used in an ISR")
            return
        for block in self.blocks:
            code = "E324" if block.kind == "for" else "E323"
            self.sink.add(code, node.span, f"LABEL inside {block.kind.upper()} block"
                          + (" (its body is inside an IF)" if block.kind == "while" else ""),
                          hint="labels must stand outside FOR and IF blocks; jumping out of "
                          "a block is fine")
            return
        if node.label.upper() in self.labels:
            self.emit("LABEL", (self.labels[node.label.upper()],), node.span)

    def lower_goto(self, node: ast.Goto) -> None:
        if self.kind == "isr":
            self.sink.add("E327", node.span, "GOTO cannot be used in an ISR")
            return
        key = node.label.upper()
        if key not in self.labels:
            if key.isdigit() and int(key) > self.profile.limit("label_max"):
                self.sink.add("E326", node.span, f"label {key} does not exist: labels are "
                              f"0..{self.profile.limit('label_max')}")
            else:
                hint = did_you_mean(node.label, list(self.labels))
                hint = f"{hint} (jumps stay inside one program)" if hint else \
                    "jumps stay inside one program"
                self.sink.add("E325", node.target_span or node.span, f"GOTO {node.label}: no "
                              f"LABEL {node.label} in this program", hint=hint)
            return
        self.emit("GOTO", (self.labels[key],), node.span)

    def lower_call(self, node: ast.CallStmt) -> None:
        command = self.cat.macro("MP_CALL")
        if not self.command_allowed(command, node.span):
            return
        upper = node.target.upper()
        program = PROGRAM_RE.fullmatch(upper)
        ref: ProgramRef
        if program and program.group(1) == "ISR":
            self.sink.add("E431", node.span, f"CALL {node.target}: ISRs are started by "
                          "interrupts, not called")
            return
        if program or upper.isdigit():
            slot = int(program.group(2) if program else upper)
            if slot not in self.profile.slot_numbers("mp"):
                self.sink.add("E501", node.target_span or node.span,
                              f"MP{slot} does not exist: slots are "
                              f"MP1..MP{max(self.profile.slot_numbers('mp'))}")
                return
            ref = ProgramRef(slot=slot)
        elif upper in self.program_names:
            target = self.program_names[upper]
            if target.kind != "mp":
                self.sink.add("E431", node.span, f"CALL {node.target}: it is an ISR")
                return
            ref = ProgramRef(name=upper)
        else:
            hint = did_you_mean(node.target, list(self.program_names)) or \
                "CALL a program of this build by name, or any slot as MPn"
            self.sink.add("E434", node.target_span or node.span,
                          f"no program named {node.target!r} in this build", hint=hint)
            return
        self.out.calls.append(CallSite(ref, node.span))
        self.emit_command(command, (ref,), node.span)
