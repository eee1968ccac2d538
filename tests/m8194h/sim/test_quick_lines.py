"""The interpreter's quick path (`precompile.Prepared.quick`: the clock and the pc held in
locals over a stretch of variable and control-flow lines) against the semantics of the
lines, computed here by a reference that knows nothing of the interpreter: random programs
of assignments, arithmetic, IF/ELSE, FOR (constant and variable counts), EXIT FOR and
GOTO/LABEL end with the variables, the number of lines and the clock the semantics give
(every line, and the closing line, costs the profile's line time), whether they run in one
call, in slices cut by a line budget or by a time horizon, or under a `before_line` hook,
which must see every line, in order, before it runs."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.image import BuildResult
from mplang.m8194h.sim import loops, precompile
from mplang.m8194h.sim.controller import Frame, VirtualController
from mplang.m8194h.sim.preload import preload

LIMIT = 2_000_000_000
VALUES = st.one_of(st.integers(-5, 5), st.integers(-LIMIT, LIMIT),
                   st.sampled_from([LIMIT, -LIMIT, 65535, 46341]))
DATA = st.integers(1, 6)  # VAR1..VAR6 hold data; VAR7.. count loops; VAR20.. guard GOTOs


@dataclass(frozen=True)
class Set:
    dest: int
    value: int | str  # a constant or "VARn"


@dataclass(frozen=True)
class Calc:
    dest: int
    left: int  # always a variable: the compiler folds constant expressions
    op: str
    right: int | str


@dataclass(frozen=True)
class If:
    left: int
    cmp: str
    right: int | str
    then: tuple[object, ...]
    other: tuple[object, ...] | None


@dataclass(frozen=True)
class For:
    count: int | None  # None: counted by a variable set just before to `start`
    start: int
    body: tuple[object, ...]


@dataclass(frozen=True)
class ExitFor:
    pass


OPERAND = st.one_of(DATA.map(lambda n: f"VAR{n}"), VALUES)
SIMPLE = st.one_of(st.builds(Set, DATA, OPERAND),
                   st.builds(Calc, DATA, DATA, st.sampled_from("+-*&|"), OPERAND))


def _blocks(depth: int, in_for: bool) -> st.SearchStrategy[tuple[object, ...]]:
    if depth == 0:
        return st.lists(SIMPLE, min_size=1, max_size=3).map(tuple)
    inner = _blocks(depth - 1, in_for)
    choices = [
        SIMPLE,
        st.builds(If, DATA, st.sampled_from(["<", ">", "<=", ">=", "==", "!="]), OPERAND,
                  inner, st.one_of(st.none(), inner)),
        st.builds(For, st.one_of(st.none(), st.integers(0, 3)), st.integers(-1, 3),
                  _blocks(depth - 1, True))]
    if in_for:
        choices.append(st.builds(If, DATA, st.just(">"), VALUES, st.just((ExitFor(),)),
                                 st.none()))
    return st.lists(st.one_of(*choices), min_size=1, max_size=4).map(tuple)


@dataclass(frozen=True)
class Program:
    body: tuple[object, ...]
    rounds: int  # > 0: the body runs under LABEL 1 ... GOTO 1 (from inside a FOR) this often


PROGRAMS = st.builds(Program, _blocks(2, False), st.integers(0, 3))


class Reference:
    """The program as source, and what the semantics make of it: each statement is one
    macro line; a jump goes to the line after its target (the ELSE / END_IF / NEXT / LABEL
    it names is skipped)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.vars = [0] * 32
        self.trace: list[int] = []  # pcs in the order they run

    def render(self, program: Program) -> str:
        self.text: list[str] = []
        if program.rounds:
            self._emit("VAR20 = 0")
            self._emit("LABEL 1")
            self._emit("VAR20 = VAR20 + 1")
            self._emit("FOR 2")
        self._render(program.body, 0)
        if program.rounds:
            self._emit(f"IF VAR20 < {program.rounds}")
            self._emit("GOTO 1")
            self._emit("END IF")
            self._emit("NEXT")
        return "MP 156\n" + "\n".join(f"  {line}" for line in self.text) + "\nEND MP\n"

    def _emit(self, text: str) -> None:
        self.text.append(text)

    def _render(self, body: tuple[object, ...], depth: int) -> None:
        for s in body:
            if isinstance(s, Set):
                self._emit(f"VAR{s.dest} = {_operand(s.value)}")
            elif isinstance(s, Calc):
                self._emit(f"VAR{s.dest} = VAR{s.left} {s.op} {_operand(s.right)}")
            elif isinstance(s, If):
                self._emit(f"IF VAR{s.left} {s.cmp} {_operand(s.right)}")
                self._render(s.then, depth)
                if s.other is not None:
                    self._emit("ELSE")
                    self._render(s.other, depth)
                self._emit("END IF")
            elif isinstance(s, ExitFor):
                self._emit("EXIT FOR")
            else:
                assert isinstance(s, For)
                counter = 7 + depth
                if s.count is None:
                    self._emit(f"VAR{counter} = {s.start}")
                self._emit(f"FOR {s.count if s.count is not None else f'VAR{counter}'}")
                self._render(s.body, depth + 1)
                self._emit("NEXT")

    # ------------------------------------------------------------------ semantics
    def run(self, program: Program) -> None:
        self.pc = 0
        if not program.rounds:
            self._run(program.body, 0)
            return
        self._line()  # VAR20 = 0
        self.vars[20] = 0
        label = self.pc
        self._line()  # LABEL 1 (run when reached in order)
        while True:
            self.pc = label + 1
            self._line()
            self.vars[20] += 1
            self._line()  # FOR 2
            jumped = False
            for turn in range(2):
                self.pc = label + 3
                exited = self._run(program.body, 0)
                assert not exited  # EXIT FOR stands inside its own FOR
                self._line()  # IF VAR20 < rounds
                if self.vars[20] < program.rounds:
                    self._line()  # GOTO 1: leaves the FOR, on at the line after the LABEL
                    jumped = True
                    break
                self.pc += 2  # (GOTO and END IF skipped: on at the NEXT)
                self._line()  # NEXT
                if turn == 1:
                    return
            if not jumped:
                return

    def _line(self) -> None:
        self.trace.append(self.pc)
        self.pc += 1

    def _run(self, body: tuple[object, ...], depth: int) -> bool:
        """Run a block from `self.pc` (its first line); True if EXIT FOR left the loop."""
        for s in body:
            if isinstance(s, Set):
                self._line()
                self.vars[s.dest] = _wrap(self._value(s.value))
            elif isinstance(s, Calc):
                self._line()
                left, right = self.vars[s.left], self._value(s.right)
                result = {"+": left + right, "-": left - right, "*": left * right,
                          "&": left & right, "|": left | right}[s.op]
                self.vars[s.dest] = _wrap(result)
            elif isinstance(s, If):
                if self._if(s, depth):
                    return True
            elif isinstance(s, ExitFor):
                self._line()
                return True
            else:
                assert isinstance(s, For)
                self._for(s, depth)
        return False

    def _if(self, s: If, depth: int) -> bool:
        start = self.pc
        self._line()
        holds = {"<": int.__lt__, ">": int.__gt__, "<=": int.__le__, ">=": int.__ge__,
                 "==": int.__eq__, "!=": int.__ne__}[s.cmp](self.vars[s.left],
                                                           self._value(s.right))
        then_len = _length(s.then)
        else_len = _length(s.other) if s.other is not None else None
        end = start + 1 + then_len + (1 + else_len if else_len is not None else 0)  # END IF
        if holds:
            if self._run(s.then, depth):
                return True
            if else_len is not None:
                self._line()  # ELSE: on after END IF
                self.pc = end + 1
            else:
                self._line()  # END IF
            return False
        if else_len is not None:
            self.pc = start + 1 + then_len + 1
            if self._run(s.other or (), depth):
                return True
            self._line()  # END IF
            return False
        self.pc = end + 1
        return False

    def _for(self, s: For, depth: int) -> None:
        counter = 7 + depth
        if s.count is None:
            self._line()
            self.vars[counter] = s.start
            count = s.start
        else:
            count = s.count
        start = self.pc
        self._line()  # FOR
        after = start + 1 + _length(s.body) + 1  # the line after NEXT
        if count <= 0:
            self.pc = after
            return
        while True:
            self.pc = start + 1
            if self._run(s.body, depth + 1):
                self.pc = after
                return
            self._line()  # NEXT
            count -= 1
            if s.count is None:
                self.vars[counter] = count
            if count <= 0:
                return

    def _value(self, operand: int | str) -> int:
        return self.vars[int(operand[3:])] if isinstance(operand, str) else operand


def _operand(value: int | str) -> str:
    return value if isinstance(value, str) else str(value)


def _wrap(value: int) -> int:
    value &= 0xFFFFFFFF
    return value - (1 << 32) if value & 0x80000000 else value


def _length(body: tuple[object, ...]) -> int:
    """Macro lines of a block."""
    total = 0
    for s in body:
        if isinstance(s, If):
            total += 2 + _length(s.then) + (1 + _length(s.other) if s.other is not None
                                            else 0)
        elif isinstance(s, For):
            total += 2 + _length(s.body) + (1 if s.count is None else 0)
        else:
            total += 1
    return total


def _expected(program: Program, line_time: float) -> tuple[Reference, str, float]:
    ref = Reference()
    source = ref.render(program)
    ref.run(program)
    clock = 0.0
    for _ in range(len(ref.trace) + 1):  # every line run, and the closing line
        clock += line_time
    return ref, source, clock


def _controller(build: BuildResult) -> VirtualController:
    vc = VirtualController()
    preload(vc, build)
    vc.call(156)
    return vc


@settings(max_examples=60, deadline=None, derandomize=True)
@given(program=PROGRAMS, budget=st.integers(1, 9))
def test_lines_run_as_their_semantics_say(program: Program, budget: int) -> None:
    vc = VirtualController()
    ref, source, clock = _expected(program, vc.line_time)
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    assert len(ref.text) == len(_controller(build).tables[("mp", 156)].lines)

    whole = _controller(build)  # in one run
    result = whole.run()
    assert (result.finished, result.steps, whole.clock) == (True, len(ref.trace), clock)
    assert whole.vars[:24] == ref.vars[:24]

    sliced, steps = _controller(build), 0  # cut every `budget` lines
    while sliced.stack:
        steps += sliced.advance(3600.0, max_steps=budget, until_idle=True)
    assert (steps, sliced.clock, sliced.vars[:24]) == (len(ref.trace), clock, ref.vars[:24])

    starts, t = [], 0.0  # the clock as each line starts
    for _ in range(len(ref.trace)):
        starts.append(t)
        t += vc.line_time
    timed, steps, until = _controller(build), 0, 0.0  # cut every `budget` line times
    while timed.stack:
        until += budget * vc.line_time * 0.7  # (horizons fall inside fused blocks too)
        steps += timed.advance(until)
        assert steps == sum(1 for start in starts if start < until)  # each line it may
    assert (steps, timed.vars[:24]) == (len(ref.trace), ref.vars[:24])

    seen: list[tuple[int, float]] = []
    hooked = _controller(build)  # under a debugger's hook, stopping now and then

    def before(frame: Frame) -> bool:
        seen.append((frame.pc, hooked.clock))
        return len(seen) % (budget + 1) == 0

    hooked.before_line = before
    steps = 0
    while hooked.stack:
        steps += hooked.advance(3600.0, until_idle=True)
    end = len(ref.text)
    pcs = [pc for pc, _t in seen]
    # a stop leaves the line unrun: the hook sees it again when the run resumes
    resumed = [pc for i, pc in enumerate(pcs) if not (i and (i % (budget + 1)) == 0)]
    assert resumed == [*ref.trace, end]
    times = [t for i, (_pc, t) in enumerate(seen) if not (i and (i % (budget + 1)) == 0)]
    expected_times, t = [], 0.0
    for _ in range(len(ref.trace) + 1):
        expected_times.append(t)
        t += vc.line_time
    assert times == expected_times
    assert (steps, hooked.clock, hooked.vars[:24]) == (len(ref.trace), clock, ref.vars[:24])


def _broken_loop(prepared: bool) -> tuple[object, ...]:
    source = "MP 156\n  FOR 3\n    VAR1 = VAR1 + 1\n  NEXT\nEND MP\n"
    with pytest.MonkeyPatch.context() as patch:
        if not prepared:
            patch.setattr(precompile, "prepare", lambda _vc, _t, _pc, _n, handler: handler)
        vc = _controller(compile_source(source))
        vc.advance(3600.0, max_steps=2)  # FOR and the first VAR1 = VAR1 + 1
        frame = vc.stack[-1]
        frame.loops.clear()
        result = vc.run()
    return (result.finished, result.steps, result.time_s, result.error, result.failure,
            vc.execution_error, frame.pc, vc.vars[1])


def test_a_failing_quick_line_fails_as_its_handler_would() -> None:
    """A NEXT whose loop is gone (its frame's loops emptied from outside) raises inside a
    quick line: the error, its place, the line count and the clock are the generic
    handler's."""
    quick = _broken_loop(True)
    assert quick == _broken_loop(False)
    assert quick[:2] == (False, 1) and quick[5][3] == 2  # at the NEXT (slot line 2)


def test_straight_lines_run_as_fused_blocks_that_slices_cut() -> None:
    """A loop body of arithmetic and an IF runs as blocks (`blocks.fuse`); a line budget or
    a horizon that ends inside a block runs its lines one by one up to exactly that line."""
    source = ("MP 156\n  FOR 4\n    VAR1 = VAR1 + 3\n    VAR2 = VAR1 * 2\n"
              "    IF VAR2 > 10\n      VAR2 = VAR2 - 10\n    END IF\n  NEXT\nEND MP\n")
    build = compile_source(source)
    vc = _controller(build)
    fused = vc.prepared(vc.tables[("mp", 156)]).fused
    assert [None if f is None else f[1] for f in fused] == [None, 3, None, None, 3, None,
                                                            None, None]
    whole = vc.run()
    lt = vc.line_time
    for budget in range(1, 8):
        cut, steps, clocks = _controller(build), 0, []
        while cut.stack:
            steps += cut.advance(3600.0, max_steps=budget, until_idle=True)
            clocks.append(cut.clock)
        assert (steps, cut.clock, cut.vars[:3]) == (whole.steps, vc.clock, vc.vars[:3])
        expected, t = [], 0.0
        for _ in range(whole.steps):
            t += lt
            expected.append(t)
        assert clocks[:-1] == expected[budget - 1::budget][:len(clocks) - 1]


def _slices(build: BuildResult, budget: int, compiled: bool) -> list[object]:
    """The state after every slice of a run cut every `budget` lines, then every `budget`
    line times (horizons inside a loop's turn), with the loops compiled (`loops`) or not."""
    seen: list[object] = []
    with pytest.MonkeyPatch.context() as patch:
        if not compiled:
            patch.setattr(loops, "source", lambda *_args: None)
        for by_time in (False, True):
            vc, until = _controller(build), 0.0
            while vc.stack:
                until += budget * vc.line_time * 0.7
                ran = vc.advance(until) if by_time else \
                    vc.advance(3600.0, max_steps=budget, until_idle=True)
                seen.append((ran, vc.clock, [(f.pc, list(f.loops)) for f in vc.stack],
                             vc.vars[:24]))
    return seen


@settings(max_examples=40, deadline=None, derandomize=True)
@given(program=PROGRAMS, budget=st.integers(1, 40))
def test_compiled_loops_leave_every_slice_as_the_blocks_do(program: Program,
                                                           budget: int) -> None:
    """A compiled loop runs the turns that fit and stops where the lines run one block at a
    time would: the same lines, clock, pcs, loops and variables after every slice."""
    build = compile_source(Reference().render(program))
    assert _slices(build, budget, True) == _slices(build, budget, False)


def _tampered(build: BuildResult, change: str, compiled: bool) -> tuple[object, ...]:
    """A run whose frame's loops were changed from outside at the inner loop's body: the
    innermost one dropped ("pop") or all of them ("clear")."""
    with pytest.MonkeyPatch.context() as patch:
        if not compiled:
            patch.setattr(loops, "source", lambda *_args: None)
        vc = _controller(build)
        vc.advance(3600.0, max_steps=3)  # FOR 2, VAR3 = 5, FOR 5
        frame = vc.stack[-1]
        assert frame.pc == 3
        frame.loops.pop() if change == "pop" else frame.loops.clear()
        result = vc.run(max_steps=500)
    return (result.finished, result.steps, result.time_s, result.error, result.failure,
            frame.pc, frame.loops, vc.vars[:4])


def test_an_innermost_loop_runs_its_turns_in_one_call() -> None:
    """The loop of arithmetic and an IF / ELSE is compiled (the outer loop, holding it, is
    not) and gives what its lines give one block at a time; a frame whose loops were
    changed from outside runs its lines the ordinary way (the loop declines), to the same
    end or the same error."""
    source = ("MP 156\n  FOR 2\n    VAR3 = 5\n    FOR 5\n      VAR1 = VAR1 + 3\n"
              "      IF VAR1 > 10\n        VAR2 = VAR2 + VAR1\n      ELSE\n"
              "        VAR2 = VAR2 - 1\n      END IF\n    NEXT\n  NEXT\nEND MP\n")
    build = compile_source(source)
    vc = _controller(build)
    entries = [f is not None and f[3] is not None
               for f in vc.prepared(vc.tables[("mp", 156)]).fused]
    assert [pc for pc, looped in enumerate(entries) if looped] == [3]
    result = vc.run()
    assert result.finished and (vc.vars[1], vc.vars[2]) == (30, 144)
    assert _slices(build, 7, True) == _slices(build, 7, False)
    cleared = _tampered(build, "clear", True)
    assert cleared == _tampered(build, "clear", False)
    assert cleared[0] is False and cleared[4] is not None  # the NEXT fails
    popped = _tampered(build, "pop", True)
    assert popped == _tampered(build, "pop", False)
    assert popped[0] is True
