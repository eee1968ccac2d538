"""The CSIM checker: each rule on a minimal line, and the host/program contexts."""

from __future__ import annotations

import pytest

from mplang.csim import profile
from mplang.csim.check import Checker
from mplang.csim.syntax import parse_text
from mplang.lang.diagnostics import DiagnosticSink


def codes(text: str, context: str = "program") -> list[str]:
    sink = DiagnosticSink()
    script = parse_text(text, "t", "t.csim", sink)
    checker = Checker(profile.load(), sink, context)
    if context == "program":
        checker.script(script)
    else:
        for statement in script.statements:
            checker.statement(statement)
    return [d.code for d in sink.sorted()]


@pytest.mark.parametrize(("text", "expected"), [
    ("MA 10000\n2MA 100,50\nAA 50,150,-720\nSET EV1 NZ,N0\nON EV1,$P\n$P\nRET\n", []),
    ("MOVE 3\n", ["E702"]),
    ("TVM 3\n", ["E702"]),
    ("MA 1,2\n", ["E703"]),
    ("JZ R1,$A\n$A\n", ["E704"]),
    ("JE N1,R1,$A\n$A\n", ["E704"]),
    ("JE 1.5,N1,$A\n$A\n", ["E704"]),
    ("JE 40000,N1,$A\n$A\n", ["E705"]),
    ("WT 1.5\n", ["E704"]),
    ("JI 9,$A\n$A\n", ["E705"]),
    ("SET P0\n", ["E705"]),
    ("OUTP 16\n", ["E705"]),
    ("FT 0\n", ["E705", "W702"]),
    ("CM 3\n", ["E705"]),
    ("TX=6\n", ["E705"]),
    ("N1=32767\n", ["E705"]),
    ("N1=0.5\n", ["E704"]),
    ("N65=1\n", ["E706"]),
    ("RS(2001)=1\n", ["E706"]),
    ("T8MA 1\n", ["E707"]),
    ("T1XMA 1\n", ["E707"]),
    ("JP $NOWHERE\n", ["E708"]),
    ("$A\n$a\n", ["E709"]),
    ("JP 7\n", ["E710"]),
    ("G\n", ["E711"]),
    ("?PE\n", ["E711"]),
    ("PN37=0\n", ["E711"]),
    ("SPEED=3\n", ["E712"]),
    ("N1=N1+1\n", ["W701"]),
    ("R1=N1\n", ["W701"]),
    ("SPI 1,2,3,4\n", ["W702"]),
    ("PN99=3\n", ["W703"]),
    ("JP $A\nMA 1\n$A\n", ["W704"]),
    ("N1=N1/0\n", ["E705", "W701"]),
])
def test_rules(text: str, expected: list[str]) -> None:
    assert sorted(codes(text)) == sorted(expected)


def test_host_context() -> None:
    assert codes("G $A\n?PE\n?t1err\n?N3\nPL\nMA 5\n", "immediate") == []
    assert codes("JP 3\n", "immediate") == ["E711"]
    assert codes("2MR R1,R2\n", "immediate") == ["E711"]  # CS 183: variables program-only
    assert codes("2MA R1,R2\n", "immediate") == []  # CS 181: both
    assert codes("?FOO\n", "immediate") == ["E702"]
    assert codes("?IN 9\n", "immediate") == ["E705"]
    assert codes("?IN\n", "immediate") == ["E703"]


def test_messages_name_the_manual_and_suggest() -> None:
    sink = DiagnosticSink()
    script = parse_text("JNZZ N1,$A\n$A\n", "t", "t.csim", sink)
    Checker(profile.load(), sink).script(script)
    (diagnostic,) = sink.items
    assert diagnostic.hint == "did you mean JNZ?"
    assert str(diagnostic.span) == "t.csim:1:1"
