"""Machine data of the virtual M8194H (manual 3.19) through its Python face,
`VirtualController.md`, and the `--memory` file. The Modbus side is tested in
tests/m8194h/test_modbus_device_face.py."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.machine_data import bits_float, float_bits, shortest_float


def test_3_19_longs_and_floats_by_number() -> None:
    """MD0-1023 are longs, MD1024-2047 floats (RS 2518); 321.65 is 0x43A0D333 (RS 2640)."""
    vc = VirtualController()
    md = vc.md
    assert md.read(0) == 0 and md.read(2047) == 0.0
    md.write(100, 0x12345678)
    md.write(1023, -(1 << 31))
    md.write(1500, 321.65)
    md.write(1024, 7)  # an int in a float MD is that float
    assert md.read(100) == 0x12345678 and md.read(1023) == -(1 << 31)
    assert md.word(1500) == 0x43A0D333 and md.read(1024) == 7.0
    assert isinstance(md.read(1024), float) and isinstance(md.read(100), int)
    assert not md.is_float(1023) and md.is_float(1024)
    md.set_word(2047, 0x7FC00000)  # any bits through the registers, a NaN too
    assert math.isnan(md.read(2047))


@pytest.mark.parametrize(("number", "value", "why"), [
    (2048, 0, "MD0..MD2047"), (-1, 0, "MD0..MD2047"), (5, 1 << 31, "holds a long"),
    (5, 1.5, "holds a long"), (5, True, "holds a long"), (1500, "1", "holds a float"),
    (1500, math.inf, "holds a float"), (1500, 1e39, "float range"),
])
def test_3_19_values_outside_the_manuals_ranges_are_refused(number: int, value: object,
                                                             why: str) -> None:
    vc = VirtualController()
    with pytest.raises(ValueError, match=why):
        vc.md.write(number, value)  # type: ignore[arg-type]
    assert vc.md.words == [0] * 2048 and vc.memory_version == 0


def test_3_19_a_change_is_a_non_volatile_one() -> None:
    """Every change makes `mpc sim --memory` save; writing the same value again does not."""
    vc = VirtualController()
    vc.md.write(3, 9)
    first = vc.memory_version
    vc.md.write(3, 9)
    assert first > 0 and vc.memory_version == first


def test_3_19_machine_data_are_saved_and_restored(tmp_path: Path) -> None:
    vc = VirtualController()
    vc.md.write(100, -5)
    vc.md.write(1500, 321.65)
    vc.md.set_word(2000, 0xFF800000)  # -inf: kept as its word
    path = tmp_path / "fram.json"
    vc.save(path)
    data = json.loads(path.read_text())
    assert data["machine_data"] == {"MD100": -5, "MD1500": 321.65, "MD2000": "0xff800000"}
    again = VirtualController()
    again.md.write(7, 1)  # not in the file: 0 after the restore
    again.restore(path)
    assert again.md.words == vc.md.words
    del data["machine_data"]  # a file from before machine data were kept
    path.write_text(json.dumps(data))
    old = VirtualController()
    old.restore(path)
    assert old.md.words == [0] * 2048


@pytest.mark.parametrize(("saved", "message"), [
    ([1, 2], "must be an object"), ({"MD2048": 1}, "not MD0..MD2047"),
    ({"VAR1": 1}, "not MD0..MD2047"), ({"MD5": 1.5}, "MD5: MD5 holds a long"),
    ({"MD1500": "zz"}, "not a hex word"), ({"MD1500": "0x1FFFFFFFF"}, "32-bit word"),
    ({"MD5": "0x10"}, "MD5 holds a long"),
])
def test_3_19_a_broken_memory_file_names_the_entry(saved: object, message: str) -> None:
    vc = VirtualController()
    vc.md.write(1, 1)
    with pytest.raises(ValueError, match=message):
        vc.md.from_json(saved)
    assert vc.md.read(1) == 1  # nothing changed


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 0xFFFFFFFF), st.integers(0, 2047))
def test_3_19_every_md_word_survives_the_memory_file(word: int, number: int) -> None:
    """Whatever bits a host wrote, the memory file gives them back: a long as its value, a
    float as the shortest decimal of the same float32, a NaN or infinity as its word."""
    vc = VirtualController()
    vc.md.set_word(number, word)
    text = json.dumps(vc.md.to_json())
    again = VirtualController()
    again.md.from_json(json.loads(text))
    assert again.md.word(number) == word
    if vc.md.is_float(number) and math.isfinite(bits_float(word)):
        assert float_bits(shortest_float(word)) == word
