"""The machine-file reader (`mplang.m8194h.machine`) on arbitrary input: whatever the text, it
either gives a setup or a `MachineError` whose message starts with the file and a line (never
another exception), and every event line it accepts says what it does."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mplang.m8194h.machine import MachineError, load_machine, parse_event
from mplang.m8194h.sim.scripted import TimedChange, Watch

WORDS = st.sampled_from(["at", "when", "s", "ms", "X", "Y", "W", ">=", "<", "=", ",", "EMG",
                         "DI8.3", "DI7.1", "DI9", "X.IN3", "U.ALARM", "Z.INPOS", "1", "0",
                         "2.5", "-1", "nan", "0x10", "5000", "=="])
EVENT_TEXT = st.one_of(st.text(max_size=40), st.lists(WORDS, max_size=9).map(" ".join))
SETTINGS = settings(max_examples=300, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


@SETTINGS
@given(text=EVENT_TEXT)
def test_an_event_line_is_understood_or_refused_with_a_reason(text: str) -> None:
    try:
        event = parse_event(text)
    except ValueError as exc:
        assert str(exc)
        return
    assert isinstance(event, (TimedChange, Watch)) and event.changes
    if isinstance(event, TimedChange):
        assert event.time >= 0


TOML_PIECES = st.sampled_from([
    "[machine]\n", "[machine.X]\n", "[machine.Q]\n", "[other]\n", "emg = true\n", "emg = 3\n",
    "events = [\"at 1 s EMG = 1\"]\n", "events = [1]\n", "limit-plus = 5\n",
    "limit-minus = 9\n", "home = [1, 2]\n", "home = [3]\n", "index = false\n",
    "index = { period = 4 }\n", "index = { period = 4, width = 9 }\n", "start = 1.5\n",
    "inpos = \"auto\"\n", "alarm = true\n", "[[machine]]\n", "x = \n", "\"a\" = 1\n",
])


@SETTINGS
@given(pieces=st.lists(TOML_PIECES, max_size=8))
def test_a_machine_file_loads_or_fails_at_a_line(tmp_path: Path, pieces: list[str]) -> None:
    path = tmp_path / "machine.toml"
    path.write_text("".join(pieces))
    try:
        load_machine(path)
    except MachineError as exc:
        assert re.match(rf"{re.escape(str(path))}(:\d+)?: ", str(exc)), str(exc)


@pytest.mark.parametrize(("text", "fields"), [
    ("at 2.0 s DI8.3 = 1", (2.0, "DI8.3", 8, 0x0008)),
    ("AT 250 MS di15 = 0xFFFF", (0.25, "DI15", 15, 0xFFFF)),
    ("at 0 s EMG = 1, X.IN3 = 0", (0.0, "EMG", -1, 0)),
])
def test_5_1_timed_changes_name_the_frnet_bits_they_write(
        text: str, fields: tuple[float, str, int, int]) -> None:
    event = parse_event(text)
    assert isinstance(event, TimedChange)
    change = event.changes[0]
    assert (event.time, change.name, change.group, change.mask) == fields


@pytest.mark.parametrize(("text", "threshold", "above"), [
    ("when X >= 5000 EMG = 1", 5000, True), ("when X > 5000 EMG = 1", 5001, True),
    ("when X <= 5000 EMG = 1", 5001, False), ("when X < 5000 EMG = 1", 5000, False),
])
def test_conditions_are_one_threshold_and_a_side(text: str, threshold: int,
                                                 above: bool) -> None:
    event = parse_event(text)
    assert isinstance(event, Watch)
    assert (event.axis, event.threshold, event.above) == (0, threshold, above)
