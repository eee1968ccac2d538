"""Reading FBs-PLC listings: the manual's own spelling, every line form, errors with places,
and (hypothesis) that a written listing reads back to the same tables."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.fatek.model import (
    NEXT,
    Condition,
    Contact,
    ContactEvent,
    Drive,
    Home,
    Line,
    ParamTable,
    PositioningTable,
    PulseSensor,
    Register,
    SimSetup,
    Step,
    Table,
    Value,
    WindowSensor,
)
from mplang.fatek.parser import normalise, parse_number, parse_text
from mplang.fatek.profile import load
from mplang.fatek.render import render_fbs
from mplang.lang.diagnostics import DiagnosticSink

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "fatek"


def parse(text: str) -> tuple[list[Table], SimSetup, DiagnosticSink]:
    sink = DiagnosticSink()
    parsed = parse_text(text, "t.fbs", sink)
    return parsed.tables, parsed.sim, sink


def test_the_manuals_spelling_reads_as_ascii() -> None:
    # FB 1172 and 989 print full-width commas, U+2212 minus and a full-width semicolon
    text = "001 SPD 10000\n    DRVC ADR，+，20000，Ut\n    GOTO NEXT\n" \
           "002 SPD R1002 ；脈波頻率\n    DRV ADR,−,D102,Ut\n    EXT X0\n    GOTO NEXT\n" \
           "003 SPD 3000\n    DRV ADR,－,5000,Ps\n    MEND\n"
    tables, _, sink = parse(text)
    assert sink.items == []
    (table,) = tables
    assert isinstance(table, PositioningTable)
    assert [s.motion for s in table.steps] == [
        Drive("DRVC", "ADR", "+", 20000, "Ut"), Drive("DRV", "ADR", "-", Register("D", 102), "Ut"),
        Drive("DRV", "ADR", "-", 5000, "Ps")]
    assert table.steps[1].speed == Register("R", 1002)
    assert table.steps[1].condition == Condition("EXT", contact=Contact("X", 0))


def test_normalise_keeps_columns() -> None:
    raw = "DRV ADR，−，300，Ut；comment"
    assert len(normalise(raw)) == len(raw)
    assert normalise(raw) == "DRV ADR,-,300,Ut;comment"


def test_blank_operands_and_blank_direction() -> None:
    tables, _, sink = parse("001 SPD 20000\n  DRV ABS,  ,   0 ,Ut\n  MEND\n"
                            "002 SPD R1000\n  LIN ADR,D100,D200, , ,Ut\n  MEND\n")
    assert not sink.items
    table = tables[0]
    assert isinstance(table, PositioningTable)
    assert table.steps[0].motion == Drive("DRV", "ABS", "", 0, "Ut")
    assert table.steps[1].motion == Line("LIN", "ADR", (Register("D", 100), Register("D", 200),
                                                       None, None), "Ut")


def test_headers_parameters_and_sim_lines() -> None:
    text = ("TABLE home FUN141 Ps2 SR=R2900\nP9 = 0100H\nP15 = FFFFFFFFH\nP16 = -100\n"
            "TABLE run HSPSO Ps2 SR=R5000 WR=D10\n001 SPD 5000\n DRVZ MD1\n MEND\n"
            "TABLE lines MHSPO Gp1\n001 SPD 5\n LINE ADR,1,2,3,4,Ps\n EXT M5\n GOTO R7\n"
            "SIM DR1000 = -2\nSIM R5 = 7\nSIM X3 ON AT 1.5\nSIM X3 OFF AT 2\n"
            "SIM X0 ON WHILE Ps1 IN -10..20\nSIM X4 PULSE Ps0 EVERY 2000\n")
    tables, sim, sink = parse(text)
    assert not sink.items
    params, run, lines = tables
    assert isinstance(params, ParamTable) and params.axis == 2
    assert params.values == {9: 0x100, 15: 0xFFFFFFFF, 16: -100}
    assert isinstance(run, PositioningTable) and run.fun == 140 and run.wr == Register("D", 10)
    assert run.steps[0].motion == Home(1)
    assert isinstance(lines, PositioningTable) and lines.fun == 147 and lines.unit == 1
    assert lines.steps[0].goto == Register("R", 7)
    assert sim.registers == {Register("R", 1000): 0xFFFE, Register("R", 1001): 0xFFFF,
                             Register("R", 5): 7}
    assert [e.state for e in sim.events] == [True, False]
    assert sim.windows[0].axis == 1 and (sim.windows[0].low, sim.windows[0].high) == (-10, 20)
    assert sim.pulses[0].every == 2000


def test_bad_lines_are_reported_with_their_column_and_skipped() -> None:
    text = "001 SPD 5000\n    DRV ADR,*,10,Ut\n    FROB 3\n    MEND\n"
    tables, _, sink = parse(text)
    places = sorted((d.code, d.span.line, d.span.col) for d in sink.items)
    assert places == [("E601", 2, 13), ("E601", 3, 5)]
    assert isinstance(tables[0], PositioningTable) and tables[0].steps[0].mend


def test_step_parts_out_of_order_or_twice() -> None:
    _, _, sink = parse("001 SPD 5\n  DRV ADR,+,1,Ps\n  SPD 6\n  GOTO 1\n  MEND\n")
    assert [(d.code, d.span.line) for d in sink.items] == [("E615", 3), ("E615", 5)]


def test_parse_number_forms() -> None:
    assert parse_number("0100H") == 256
    assert parse_number("FFFFFFFFH") == 0xFFFFFFFF
    assert parse_number("0x1f") == 31
    assert parse_number("-12") == -12
    assert parse_number("12Q") is None


def test_every_manual_listing_parses_cleanly() -> None:
    for path in sorted(SAMPLES.glob("*.fbs")):
        sink = DiagnosticSink()
        parse_text(path.read_text(encoding="utf-8"), path.name, sink)
        assert sink.items == [], (path.name, [d.render() for d in sink.items])


# ------------------------------------------------------------------ round trip
registers = st.builds(Register, st.sampled_from("RD"), st.integers(0, 9999))
constants = st.integers(-99_999_999, 99_999_999)
values: st.SearchStrategy[Value] = st.one_of(constants, registers)
unsigned: st.SearchStrategy[Value] = st.one_of(st.integers(0, 99_999), registers)
contacts = st.builds(Contact, st.sampled_from("XYMS"), st.integers(0, 2000))
drives = st.builds(Drive, st.sampled_from(["DRV", "DRVC"]), st.sampled_from(["ADR", "ABS"]),
                   st.sampled_from(["+", "-", ""]), values, st.sampled_from(["Ut", "Ps"]))
axes = st.one_of(st.none(), values)
lines = st.builds(Line, st.sampled_from(["LIN", "LINE"]), st.sampled_from(["ADR", "ABS"]),
                  st.tuples(axes, axes, axes, axes), st.sampled_from(["Ut", "Ps"]))
motions = st.one_of(drives, lines, st.builds(Home, st.integers(0, 9)))
conditions = st.one_of(
    st.none(),
    st.builds(Condition, st.sampled_from(["WAIT", "ACT"]), time=unsigned),
    st.builds(Condition, st.sampled_from(["WAIT", "EXT"]), contact=contacts))
targets = st.one_of(st.just(NEXT), st.integers(0, 999), registers)


@st.composite
def steps(draw: st.DrawFn, number: int) -> Step:
    mend = draw(st.booleans())
    return Step(number, draw(unsigned), draw(motions), draw(conditions),
                None if mend else draw(targets), mend)


@st.composite
def positioning_tables(draw: st.DrawFn, name: str) -> PositioningTable:
    count = draw(st.integers(1, 6))
    fun = draw(st.sampled_from([140, 147]))
    return PositioningTable(name, fun, draw(st.integers(0, 3 if fun == 140 else 1)),
                            draw(st.one_of(st.none(), registers)),
                            draw(st.one_of(st.none(), registers)),
                            [draw(steps(n)) for n in range(1, count + 1)])


@st.composite
def param_tables(draw: st.DrawFn, name: str) -> ParamTable:
    numbers = draw(st.lists(st.integers(0, 30), unique=True, max_size=6))
    return ParamTable(name, draw(st.integers(0, 3)), draw(st.one_of(st.none(), registers)),
                      {n: draw(st.integers(-(2**31), 2**32 - 1)) for n in numbers})


@st.composite
def listings(draw: st.DrawFn) -> tuple[list[Table], SimSetup]:
    count = draw(st.integers(1, 4))
    tables: list[Table] = [draw(st.one_of(positioning_tables(f"t{i}"), param_tables(f"p{i}")))
                           for i in range(count)]
    times = st.integers(0, 999_999).map(lambda n: n / 1000)
    sim = SimSetup(
        registers={r: draw(st.integers(0, 0xFFFF)) for r in draw(st.lists(registers, max_size=3))},
        events=draw(st.lists(st.builds(ContactEvent, contacts, times, st.booleans()),
                             max_size=3)),
        windows=draw(st.lists(st.builds(
            WindowSensor, contacts, st.integers(0, 3), st.integers(-100, 0), st.integers(0, 100)),
            max_size=2)),
        pulses=draw(st.lists(st.builds(PulseSensor, contacts, st.integers(0, 3),
                                       st.integers(1, 5000)), max_size=2)))
    return tables, sim


@settings(max_examples=150, deadline=None)
@given(listings())
def test_a_written_listing_reads_back_to_the_same_tables(listing: tuple[list[Table], SimSetup]
                                                         ) -> None:
    tables, sim = listing
    text = render_fbs(tables, sim, "round trip", load())
    back, back_sim, sink = parse(text)
    assert sink.items == [], [d.render() for d in sink.items]
    assert back == tables
    assert back_sim.registers == sim.registers
    assert back_sim.events == sim.events
    assert back_sim.windows == sim.windows and back_sim.pulses == sim.pulses


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(alphabet=st.characters(codec="utf-8"), max_size=40), max_size=12))
def test_any_text_gives_diagnostics_never_an_exception(text_lines: list[str]) -> None:
    text = "\n".join(text_lines)
    sink = DiagnosticSink()
    parsed = parse_text(text, "junk.fbs", sink)
    count = len(parsed.lines)
    assert all(1 <= d.span.line <= max(count, 1) for d in sink.items)
