"""`Diagnostic`, written out on `mplang.lang.record`, behaves as the frozen dataclass it was:
the same equality, hash, repr and pickles, byte for byte (the front cache on disk holds
pickled syntax diagnostics, so an entry written before still loads as the same value)."""

from __future__ import annotations

import pickle
import random
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Run, Severity, Span

# Made by the `@dataclass(frozen=True)` Diagnostic, from `_sample()` below.
DATACLASS_PICKLE_5 = bytes.fromhex(
    "80059513010000000000008c176d706c616e672e6c616e672e646961676e6f7374696373948c0a446961676e"
    "6f737469639493942981947d94288c04636f6465948c0445333031948c087365766572697479948c146d706c"
    "616e672e6c616e672e7365766572697479948c0853657665726974799493948c056572726f7294859452948c"
    "076d657373616765948c03626164948c047370616e9468008c045370616e9493942981947d94288c0466696c"
    "65948c04612e6d70948c046c696e65944b038c03636f6c944b028c07656e645f636f6c944b0575628c046869"
    "6e74948c06666978206974948c0772656c617465649468122981947d942868158c04622e6d709468174b0168"
    "184b0168194e75628c0468657265948694859475622e")
DATACLASS_PICKLE_2 = bytes.fromhex(
    "8002636d706c616e672e6c616e672e646961676e6f73746963730a446961676e6f737469630a710029817101"
    "7d7102285804000000636f646571035804000000453330317104580800000073657665726974797105636d70"
    "6c616e672e6c616e672e73657665726974790a53657665726974790a710658050000006572726f7271078571"
    "0852710958070000006d657373616765710a5803000000626164710b58040000007370616e710c636d706c61"
    "6e672e6c616e672e646961676e6f73746963730a5370616e0a710d2981710e7d710f28580400000066696c65"
    "71105804000000612e6d70711158040000006c696e6571124b035803000000636f6c71134b02580700000065"
    "6e645f636f6c71144b057562580400000068696e74711558060000006669782069747116580700000072656c"
    "617465647117680d298171187d71192868105804000000622e6d70711a68124b0168134b0168144e75625804"
    "00000068657265711b86711c85711d75622e")


def _sample() -> Diagnostic:
    return Diagnostic("E301", Severity.ERROR, "bad", Span("a.mp", 3, 2, 5), "fix it",
                      ((Span("b.mp", 1), "here"),))


def test_pickles_are_the_dataclass_pickles() -> None:
    assert pickle.dumps(_sample(), 5) == DATACLASS_PICKLE_5
    assert pickle.dumps(_sample(), 2) == DATACLASS_PICKLE_2
    assert pickle.loads(DATACLASS_PICKLE_5) == _sample()


def test_hash_and_equality_are_by_the_fields_tuple() -> None:
    made = _sample()
    assert hash(made) == hash(("E301", Severity.ERROR, "bad", Span("a.mp", 3, 2, 5), "fix it",
                               ((Span("b.mp", 1), "here"),)))
    assert made == _sample() and made != made.replace(hint="")
    assert made != made.replace(related=()) and made != made.replace(span=Span("a.mp", 3))
    assert (made == ("E301",)) is False


def test_repr_and_defaults() -> None:
    bare = Diagnostic("W107", Severity.WARNING, "m", Span("x.mp", 1))
    assert bare.hint == "" and bare.related == ()
    assert repr(bare) == ("Diagnostic(code='W107', severity=<Severity.WARNING: 'warning'>, "
                          "message='m', span=Span(file='x.mp', line=1, col=1, end_col=None), "
                          "hint='', related=())")


@pytest.mark.parametrize("name", ["code", "span"])
def test_frozen(name: str) -> None:
    with pytest.raises(AttributeError):
        setattr(_sample(), name, None)


def test_sink_keeps_each_diagnostic_once() -> None:
    sink = DiagnosticSink()
    sink.add("E202", Span("a.mp", 2, 3), "unknown name 'X'")
    sink.add("E202", Span("a.mp", 2, 3), "unknown name 'X'")
    sink.extend([_sample(), _sample(), sink.items[0]])
    assert [d.code for d in sink.items] == ["E202", "E301"]


def test_sorted_is_by_sort_key_and_stable() -> None:
    """The sink sorts by file, line, column and code; diagnostics alike in all four keep
    the order they were added in."""
    sink = DiagnosticSink()
    spans = [Span("b.mp", 2, 5), Span("a.mp", 10, 1), Span("a.mp", 2, 7, 9), Span("a.mp", 2, 7)]
    for number, span in enumerate(spans * 2):
        sink.add("W103" if number % 2 else "E202", span, f"message {number}")
    ordered = sink.sorted()
    assert ordered == sorted(sink.items, key=Diagnostic.sort_key)
    assert [d.span.file for d in ordered][:1] == ["a.mp"] and len(ordered) == 8
    alike = [d for d in ordered if d.span == Span("a.mp", 2, 7) and d.code == "W103"]
    assert [d.message for d in alike] == ["message 3", "message 7"]


def test_a_span_with_and_without_an_end_column_are_two_places() -> None:
    sink = DiagnosticSink()
    sink.add("E202", Span("a.mp", 2, 7), "m")
    sink.add("E202", Span("a.mp", 2, 7, 9), "m")
    sink.extend([Diagnostic("E202", Severity.ERROR, "m", Span("a.mp", 2, 7, 9))])
    assert [d.span.end_col for d in sink.items] == [None, 9]


def _run(*lines: int) -> Run:
    return Run(Diagnostic("W103", Severity.WARNING, "m", Span("a.mp", n)) for n in lines)


def test_a_run_enters_whole_and_each_diagnostic_once() -> None:
    """A kept run enters a sink as `add` would take its diagnostics one by one: whole when
    the sink holds none of them, else without those it holds (or that it holds twice)."""
    run = _run(1, 2, 3)
    fresh = DiagnosticSink()
    fresh.extend(run)
    assert fresh.items == list(run) and all(a is b for a, b in zip(fresh.items, run, strict=True))
    fresh.extend(run)  # its keys made once, and now all in the sink
    assert len(fresh.items) == 3
    overlapping = DiagnosticSink()
    overlapping.add("W103", Span("a.mp", 2), "m")
    overlapping.extend(run)
    assert [d.span.line for d in overlapping.items] == [2, 1, 3]
    twice = DiagnosticSink()
    twice.extend(_run(4, 4, 5))
    assert [d.span.line for d in twice.items] == [4, 5]
    after = DiagnosticSink()
    after.extend(run)
    after.add("W103", Span("a.mp", 1), "m")  # a later `add` sees what the run brought
    assert len(after.items) == 3


@pytest.mark.parametrize("change", [
    lambda run: run.append(_run(7)[0]), lambda run: run.__setitem__(0, _run(7)[0]),
    lambda run: run.__delitem__(0), lambda run: run.sort(), lambda run: run.__iadd__(run),
    lambda run: run.clear(), lambda run: run.pop()])
def test_a_run_s_keys_cannot_go_stale(change: Callable[[Run], object]) -> None:
    """Its keys are made once: a run refuses every change, so they hold what it holds."""
    run = _run(1, 2)
    DiagnosticSink().extend(run)
    with pytest.raises(TypeError, match="not changed"):
        change(run)
    assert [d.span.line for d in run] == [1, 2] and run.keys() is not None
    copied = pickle.loads(pickle.dumps(run))
    assert type(copied) is Run and copied == run


def test_sorted_with_runs_is_sorted_as_one_by_one() -> None:
    """A sink that took runs whole sorts as one that took each diagnostic by `add`: by
    sort key, stably; a run's keys are its diagnostics' as they are when sorted."""
    later, first = _run(9, 3), _run(5, 1)
    sink = DiagnosticSink()
    sink.add("E202", Span("a.mp", 4), "m")
    sink.extend(later)
    sink.extend(Run())
    sink.add("E202", Span("a.mp", 3), "m")
    sink.extend(first)
    expected = sorted(sink.items, key=Diagnostic.sort_key)
    assert sink.sorted() == expected and [d.span.line for d in expected] == [1, 3, 3, 4, 5, 9]
    moved = sink.items.pop(1)  # the sink's list changed: a run no longer where it entered
    sink.items.append(moved)
    assert sink.sorted() == expected
    assert [d.span.line for d in sink.sorted()] == [1, 3, 3, 4, 5, 9]


def _keyed_run(*places: tuple[int, str]) -> Run:
    """A run of warnings at (line, message): equal sort keys told apart by their message."""
    return Run(Diagnostic("W103", Severity.WARNING, message, Span("a.mp", line))
               for line, message in places)


def _ids(diagnostics: list[Diagnostic]) -> list[int]:
    return [id(d) for d in diagnostics]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(
    st.lists(st.tuples(st.integers(1, 12), st.sampled_from("ab")), min_size=1, max_size=5),
    st.tuples(st.integers(1, 12), st.sampled_from("abc"))), max_size=10),
    st.randoms(use_true_random=False))
def test_sorted_is_the_stable_sort_of_what_entered(
        entries: list[list[tuple[int, str]] | tuple[int, str]], rng: random.Random) -> None:
    """Whatever runs and single diagnostics entered, in any order (the same run objects
    again in a second sink, in another order, as the next build brings them): exactly the
    diagnostics, the same objects, in the order a stable sort by sort key gives."""
    made: list[Run | tuple[int, str]] = [_keyed_run(*e) if isinstance(e, list) else e
                                          for e in entries]
    for _ in range(2):
        sink = DiagnosticSink()
        for entry in made:
            if isinstance(entry, Run):
                sink.extend(entry)
            else:
                sink.add("W103", Span("a.mp", entry[0]), entry[1])
        assert _ids(sink.sorted()) == _ids(sorted(sink.items, key=Diagnostic.sort_key))
        rng.shuffle(made)
