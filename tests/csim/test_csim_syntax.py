"""Reading CSIM lines: every line form, the error positions, and properties of the parser."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from mplang.csim.syntax import parse_line, parse_text, strip_comment
from mplang.lang.diagnostics import DiagnosticSink


def parse(text: str):  # type: ignore[no-untyped-def]
    sink = DiagnosticSink()
    return parse_line(text, "t.csim", 1, sink), sink


def test_command_with_prefix_and_operands() -> None:
    statement, sink = parse("T2MR R3  # relative")
    assert not sink.items
    assert (statement.kind, statement.name, statement.prefix) == ("command", "MR", 2)
    assert [(o.kind, o.index) for o in statement.operands] == [("rvar", 3)]
    assert statement.text == "T2MR R3"


def test_names_starting_with_t_are_not_prefixes() -> None:
    for text, name in (("TAPZ", "TAPZ"), ("TASTOP", "TASTOP"), ("T1H", "H"), ("2MA 1,2", "2MA")):
        statement, _ = parse(text)
        assert statement.name == name


def test_two_word_commands() -> None:
    ev, _ = parse("SET EV1 NZ,N0")
    assert ev.name == "SET EV"
    assert [o.kind for o in ev.operands] == ["event", "word", "nvar"]
    on, _ = parse("ON EV1,$PPZ")
    assert on.name == "ON EV" and on.operands[1].kind == "label"
    assert parse("CLR BUF")[0].name == "CLR BUF"
    assert parse("CLR P2")[0].name == "CLR"
    assert parse("SAVE P")[0].name == "SAVE P"
    assert parse("RESET H")[0].name == "RESET H"
    assert parse("RESET")[0].name == "RESET"


def test_assignments() -> None:
    simple, _ = parse("N3=-5")
    assert simple.kind == "assign" and simple.target.canonical == "N3"
    assert simple.operator is None and simple.operands[0].value == -5
    arithmetic, _ = parse("R1 = R1 * -2.5")
    assert arithmetic.operator == "*"
    assert [o.text for o in arithmetic.operands] == ["R1", "-2.5"]
    minus, _ = parse("N1=N1-1")
    assert minus.operator == "-" and minus.operands[1].value == 1
    array, _ = parse("ns(12)=4")
    assert array.target.kind == "nsvar" and array.target.index == 12
    parameter, _ = parse("T2PR3=200")
    assert parameter.is_parameter_assignment and parameter.prefix == 2
    assert parameter.name == "PR3"


def test_queries() -> None:
    query, _ = parse("?t1err")
    assert (query.kind, query.name, query.prefix) == ("query", "ERR", 1)
    assert parse("?IN 3")[0].operands[0].value == 3
    assert parse("?NS(5)")[0].operands[0].kind == "nsvar"


def test_labels_and_comments() -> None:
    label, _ = parse("  $Loop_1   # the loop")
    assert (label.kind, label.name) == ("label", "LOOP_1")
    assert strip_comment('OUT "a # b" # c') == 'OUT "a # b" '
    assert parse("   # only a comment")[0] is None


def test_errors_point_at_the_column() -> None:
    for text, col in (("MA 1,,2", 6), ("MA 1,", 5), ("$A B", 1), ("MA @", 4), ("N1=N2+", 7),
                      ("N1=N2 N3", 7), ("?", 2), ("N1=", 4)):
        statement, sink = parse(text)
        assert statement is None, text
        assert [(d.code, d.span.col) for d in sink.items] == [("E701", col)], text


def test_parse_text_keeps_file_lines() -> None:
    sink = DiagnosticSink()
    script = parse_text("MA 1\n\n# c\n$X\nJP $X\n", "p", "p.csim", sink)
    assert [s.span.line for s in script.statements] == [1, 4, 5]
    assert script.labels == {"X": 1}


OPERAND = st.one_of(
    st.integers(-10**6, 10**6).map(str),
    st.floats(-1e4, 1e4, allow_nan=False).map(lambda f: f"{f:.3f}"),
    st.integers(0, 64).map(lambda i: f"N{i}"), st.integers(0, 64).map(lambda i: f"R{i}"),
    st.integers(0, 2000).map(lambda i: f"NS({i})"),
    st.from_regex(r"\$[A-Z_][A-Z0-9_]{0,8}", fullmatch=True),
)
NAME = st.sampled_from(["MA", "MR", "2MA", "JE", "JP", "CALL", "OUT", "WT", "AA", "SAR"])


@given(NAME, st.lists(OPERAND, max_size=4), st.booleans())
def test_well_formed_lines_parse_to_their_operands(name: str, operands: list[str],
                                                   spaced: bool) -> None:
    separator = ", " if spaced else ","
    text = f"{name} {separator.join(operands)}".rstrip()
    statement, sink = parse(text)
    assert not sink.items, text
    assert statement.name == name and statement.text == text
    assert [o.text for o in statement.operands] == operands


@given(st.text(max_size=40))
def test_any_text_gives_a_statement_or_a_diagnostic(text: str) -> None:
    statement, sink = parse(text.replace("\n", " ").replace("\r", " "))
    assert statement is not None or sink.items or not text.split("#")[0].strip()
