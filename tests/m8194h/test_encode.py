"""Encoder: decode(encode(x)) == x for every catalogue command, in both word orders."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.ir import catalogue
from mplang.ir.catalogue import Command, Param
from mplang.ir.macro import BVarRef, MacroLine, Operand, ProgramRef, VarRef
from mplang.lang.diagnostics import Span
from mplang.m8194h.encode import EncodeError, Encoder, join32, split32

CAT = catalogue.load()
CODED = [c for c in CAT.commands if c.code is not None]
SPAN = Span("t.mp", 1)


def operand_strategy(param: Param) -> st.SearchStrategy[Operand]:
    if param.type == "float":
        return st.floats(width=32, allow_nan=False, allow_infinity=False)
    if param.wire == 2:
        immediate = st.integers(-2_000_000_000, 2_000_000_000)
        if param.encoding == "holding_address":
            # The manual's FRNET_OUT format cannot tell an immediate 300 + 2n from VARn
            # (see the catalogue choice); decoding reads such words as variables.
            unambiguous = st.integers(0, 65535).filter(lambda v: not (300 <= v <= 1322
                                                                      and v % 2 == 0))
            return st.one_of(unambiguous, st.builds(VarRef, st.integers(0, 511)))
        return st.one_of(immediate, st.builds(VarRef, st.integers(0, 511)))
    if param.kind == "bvar":
        return st.one_of(st.integers(0, 7), st.builds(BVarRef, st.integers(0, 127)))
    if param.type == "short":
        return st.integers(-0x8000, 0x7FFF)
    return st.integers(0, 0xFFFF)


@st.composite
def lines(draw: st.DrawFn) -> tuple[Command, tuple[Operand, ...]]:
    command = draw(st.sampled_from(CODED))
    operands = tuple(draw(operand_strategy(p)) for p in command.params)
    return command, operands


@settings(max_examples=400, deadline=None)
@given(lines(), st.sampled_from([0, 1]))
def test_round_trip(line: tuple[Command, tuple[Operand, ...]], word_order: int) -> None:
    command, operands = line
    encoder = Encoder(CAT, word_order)
    frame = encoder.frame(MacroLine(command, operands, SPAN))
    assert len(frame) == command.registers
    assert all(0 <= word <= 0xFFFF for word in frame)
    decoded_command, decoded = encoder.decode(frame)
    assert decoded_command is command or decoded_command.code == command.code
    assert decoded == operands


@pytest.mark.parametrize("command", CODED, ids=[c.name for c in CODED])
def test_register_count_matches_catalogue(command: Command) -> None:
    operands = tuple(0 for _ in command.params)
    frame = Encoder(CAT).frame(MacroLine(command, operands, SPAN))
    assert len(frame) == command.registers


def test_word_order_swaps_only_32_bit_halves() -> None:
    move = CAT.macro("FIXED_MOVE")
    line = MacroLine(move, (1, -3000), SPAN)
    assert Encoder(CAT, 0).frame(line) == [0x0C4E, 1, 0xFFFF, 0xF448]  # RS 1440: FFFF F448
    assert Encoder(CAT, 1).frame(line) == [0x0C4E, 1, 0xF448, 0xFFFF]


def test_variable_operand_is_7fff_plus_index() -> None:
    line = MacroLine(CAT.macro("SET_VAR"), (VarRef(1), 100), SPAN)
    assert Encoder(CAT).frame(line) == [0x0CD2, 0x7FFF, 0x0001, 0x0000, 0x0064]


def test_split_and_join_are_inverse() -> None:
    for value in (0, 1, -1, 2_000_000_000, -2_000_000_000, 0x7FFF0001):
        for order in (0, 1):
            assert join32(split32(value, order), order, signed=value < 0) == value


def test_float_parameter_is_ieee_single() -> None:
    floats = [(c, i) for c in CODED for i, p in enumerate(c.params) if p.type == "float"]
    for command, index in floats:
        operands = tuple(321.65 if i == index else 0 for i in range(len(command.params)))
        frame = Encoder(CAT).frame(MacroLine(command, operands, SPAN))
        bits = struct.unpack(">I", struct.pack(">f", 321.65))[0]
        assert (bits >> 16, bits & 0xFFFF) == (0x43A0, 0xD333)  # RS 2650-2651
        assert [bits >> 16, bits & 0xFFFF] in [frame[k:k + 2] for k in range(len(frame))]


def test_decode_rejects_bad_frames() -> None:
    encoder = Encoder(CAT)
    with pytest.raises(EncodeError):
        encoder.decode([])
    with pytest.raises(EncodeError):
        encoder.decode([0x0001])
    with pytest.raises(EncodeError):
        encoder.decode([0x0C4E, 1])


# ------------------------------------------- what mutation testing found untested (docs/testing.md)

def test_frnet_out_sends_a_var_as_its_holding_address_and_reads_it_back() -> None:
    """RS 4398, 4406-4408: VAR1 is sent as holding address 300 + 2 x 1 = 0x012E, bVAR0 as
    0x80; an odd or out-of-range address is a plain number."""
    out = CAT.macro("FRNET_OUT")
    for order, data_words in ((0, [0x0000, 0x012E]), (1, [0x012E, 0x0000])):
        encoder = Encoder(CAT, order)
        frame = encoder.frame(MacroLine(out, (BVarRef(0), VarRef(1)), SPAN))
        assert frame == [out.code, 0x0080, *data_words]
        assert encoder.decode(frame) == (out, (BVarRef(0), VarRef(1)))
    encoder = Encoder(CAT)
    for n, address in ((0, 300), (5, 310), (511, 1322)):  # 300 + 2n
        assert encoder.frame(MacroLine(out, (BVarRef(0), VarRef(n)), SPAN))[2:] == \
            [0, address]
    frame = encoder.frame(MacroLine(out, (BVarRef(5), 7), SPAN))
    assert frame == [out.code, 0x0085, 0, 7]  # bVAR5 is 0x80 + 5
    assert encoder.decode(frame)[1] == (BVarRef(5), 7)
    assert encoder.decode([out.code, 0x0080 + 127, 0, 7])[1] == (BVarRef(127), 7)
    assert encoder.decode([out.code, 0x0080 + 128, 0, 7])[1] == (0x0100, 7)  # past bVAR127
    assert encoder.decode([out.code, 0x007F, 0, 7])[1] == (0x007F, 7)
    last = 300 + 2 * 511
    assert encoder.decode([out.code, 3, 0, last])[1] == (3, VarRef(511))
    assert encoder.decode([out.code, 3, 0, 300])[1] == (3, VarRef(0))
    # a variable number, as the disassembler prints it: VAR511, never VAR511.0
    (_, (_, var)) = encoder.decode([out.code, 3, 0, last])
    assert isinstance(var, VarRef) and repr(var.index) == "511"
    for raw in (299, 301, last + 2, 0x7FFF0001):
        assert encoder.decode([out.code, 3, *split32(raw, 0)])[1] == (3, raw)


def test_refusals_say_what_is_wrong() -> None:
    encoder = Encoder(CAT)
    with pytest.raises(ValueError, match=r"^word order is 0 or 1$"):
        Encoder(CAT, 2)
    with pytest.raises(EncodeError, match=r"^empty frame$"):
        encoder.decode([])
    with pytest.raises(EncodeError, match=r"^unknown sub-function code 0x0001$"):
        encoder.decode([1])
    move = CAT.macro("FIXED_MOVE")
    with pytest.raises(EncodeError, match=r"^FIXED_MOVE takes 4 registers, got 3$"):
        encoder.decode([move.code, 1, 0])
    no_code = next(c for c in CAT.commands if c.code is None)
    with pytest.raises(EncodeError, match=f"^{no_code.name} has no sub-function code$"):
        encoder.frame(MacroLine(no_code, tuple(0 for _ in no_code.params), SPAN))


def test_join32_is_signed_unless_told() -> None:
    assert join32([0xFFFF, 0xFFFF], 0) == -1
    assert join32([0x0000, 0x0005], 0) == 5 and join32([0x7FFF, 0xFFFF], 0) == 0x7FFFFFFF
    assert join32([0xFFFF, 0xFFFF], 0, signed=False) == 0xFFFFFFFF
    assert join32([0x0001, 0x8000], 1) == -(1 << 31) + 1


def test_the_one_float_parameter_round_trips() -> None:
    """WRITE_MD's fdata is the catalogue's only float: the random round trip, drawing over
    every command, may never meet it. IEEE-754 single, as 32 bits in the word order."""
    write_md = next(c for c in CAT.commands if c.short_name == "WRITE_MD" and c.code)
    for order, words in ((0, [0xC2F6, 0xE979]), (1, [0xE979, 0xC2F6])):
        encoder = Encoder(CAT, order)
        frame = encoder.frame(MacroLine(write_md, (1500, 0, -123.456), SPAN))
        assert frame[-2:] == words
        _, (md, ldata, fdata) = encoder.decode(frame)
        assert (md, ldata) == (1500, 0) and fdata == struct.unpack(">f", struct.pack(
            ">f", -123.456))[0]


def test_a_program_reference_is_sent_as_its_slot_or_refused_unresolved() -> None:
    """MP_CALL's operand is the called program's number (RS 9817-9842: one register after
    the code 0x0CCB). A name the linker placed is sent as the slot it was given; a name
    with no slot cannot be encoded, and the refusal names it."""
    call = CAT.macro("MP_CALL")
    encoder = Encoder(CAT)
    assert call.code == 0x0CCB
    assert encoder.frame(MacroLine(call, (ProgramRef(slot=12),), SPAN)) == [0x0CCB, 12]
    placed = MacroLine(call, (ProgramRef(name="sub"),), SPAN)
    assert encoder.frame(placed, lambda ref: 31 if ref.name == "sub" else None) == [0x0CCB, 31]
    with pytest.raises(EncodeError, match=r"^unresolved program .*'sub'"):
        encoder.frame(placed)
    assert encoder.decode([0x0CCB, 31]) == (call, (31,))


def test_the_download_s_create_and_close_frames() -> None:
    """MP_CREATE 0x0AC9 and MP_ISR_CREATE 0x0ACD take the slot number; MP_CLOSE 0x0CCA and
    MP_ISR_CLOSE 0x0CCE end the download alone (appendix table, RS 11787-11788, 11791-11792)."""
    encoder = Encoder(CAT, 1)  # the word order has no part in one-register operands
    assert encoder.create_frame("mp", 41) == [0x0AC9, 41]
    assert encoder.create_frame("isr", 7) == [0x0ACD, 7]
    assert encoder.close_frame("mp") == [0x0CCA]
    assert encoder.close_frame("isr") == [0x0CCE]
