"""Macro lines <-> Modbus sub-function frames (the registers written with FC16 at 8000).

The layout rule is the manual's 12.2.5: BYTE and WORD take one register, DWORD, long and
float two, in the device's word order (0: most significant word first). A variable operand
is 0x7FFF0000 + n, except where the catalogue marks a parameter `holding_address`
(MACRO_FRNET_OUT: 300 + 2n).
"""

from __future__ import annotations

import struct
from collections.abc import Callable

from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.macro import BVarRef, MacroLine, Operand, ProgramRef, VarRef


class EncodeError(ValueError):
    """An operand that cannot be put on the wire (the checker should have caught it)."""


def split32(value: int, word_order: int) -> list[int]:
    raw = value & 0xFFFFFFFF
    msw, lsw = raw >> 16, raw & 0xFFFF
    return [msw, lsw] if word_order == 0 else [lsw, msw]


def join32(words: list[int], word_order: int, signed: bool = True) -> int:
    msw, lsw = (words[0], words[1]) if word_order == 0 else (words[1], words[0])
    raw = (msw << 16) | lsw
    return raw - (1 << 32) if signed and raw & 0x80000000 else raw


class Encoder:
    def __init__(self, catalogue: Catalogue, word_order: int = 0) -> None:
        if word_order not in (0, 1):
            raise ValueError("word order is 0 or 1")
        self.catalogue = catalogue
        self.profile = catalogue.profile
        self.word_order = word_order
        self.var_base = self.profile.var("macro_base")
        self.holding_base = self.profile.var("holding_base")
        self.bvar_base = self.profile.var("byte_holding_base")

    def operand_value(self, param: Param, operand: Operand,
                      slot_of: Callable[[ProgramRef], int | None]) -> int | float:
        if isinstance(operand, VarRef):
            if param.encoding == "holding_address":
                return self.holding_base + 2 * operand.index
            return self.var_base + operand.index
        if isinstance(operand, BVarRef):
            return self.bvar_base + operand.index
        if isinstance(operand, ProgramRef):
            slot = slot_of(operand)
            if slot is None:
                raise EncodeError(f"unresolved program {operand}")
            return slot
        return operand

    def frame(self, line: MacroLine,
              slot_of: Callable[[ProgramRef], int | None] = lambda r: r.slot) -> list[int]:
        command = line.command
        if command.code is None:
            raise EncodeError(f"{command.name} has no sub-function code")
        registers = [command.code]
        for param, operand in zip(command.params, line.operands, strict=True):
            value = self.operand_value(param, operand, slot_of)
            if param.type == "float" and not isinstance(operand, VarRef):
                (bits,) = struct.unpack(">I", struct.pack(">f", float(value)))
                registers += split32(bits, self.word_order)
            elif param.wire == 2:
                registers += split32(int(value), self.word_order)
            else:
                registers.append(int(value) & 0xFFFF)
        return registers

    def create_frame(self, kind: str, slot: int) -> list[int]:
        short = "MP_CREATE" if kind == "mp" else "MP_ISR_CREATE"
        code = self.catalogue.rtc_by_short[short].code
        assert code is not None
        return [code, slot]

    def close_frame(self, kind: str) -> list[int]:
        code = self.catalogue.macro("MP_CLOSE" if kind == "mp" else "MP_ISR_CLOSE").code
        assert code is not None
        return [code]

    # ----------------------------------------------------------------- decoding
    def decode(self, frame: list[int]) -> tuple[Command, tuple[Operand, ...]]:
        """Inverse of `frame`: the command and its operands (program numbers as ints)."""
        if not frame:
            raise EncodeError("empty frame")
        command = self.catalogue.by_code.get(frame[0])
        if command is None:
            raise EncodeError(f"unknown sub-function code {frame[0]:#06x}")
        expected = 1 + sum(p.wire for p in command.params)
        if len(frame) != expected:
            raise EncodeError(f"{command.short_name} takes {expected} registers, got "
                              f"{len(frame)}")
        operands: list[Operand] = []
        index = 1
        for param in command.params:
            if param.wire == 2:
                words = frame[index:index + 2]
                index += 2
                raw = join32(words, self.word_order, signed=False)
                operands.append(self.decode_wide(param, raw))
            else:
                word = frame[index]
                index += 1
                operands.append(self.decode_narrow(param, word))
        return command, tuple(operands)

    def decode_wide(self, param: Param, raw: int) -> Operand:
        if param.encoding == "holding_address":
            offset = raw - self.holding_base
            if 0 <= offset < 2 * self.profile.var("count") and offset % 2 == 0 and \
                    raw >= self.holding_base:
                return VarRef(offset // 2)
        elif raw >> 16 == self.var_base >> 16:
            return VarRef(raw & 0xFFFF)
        if param.kind == "bvar" and self.bvar_base <= raw < self.bvar_base + \
                self.profile.var("byte_count"):
            return BVarRef(raw - self.bvar_base)
        if param.type == "float":
            value: float = struct.unpack(">f", struct.pack(">I", raw))[0]
            return value
        return raw - (1 << 32) if raw & 0x80000000 else raw

    def decode_narrow(self, param: Param, word: int) -> Operand:
        if param.kind == "bvar" and self.bvar_base <= word < self.bvar_base + \
                self.profile.var("byte_count"):
            return BVarRef(word - self.bvar_base)
        if param.type == "short" and word & 0x8000:
            return word - 0x10000
        return word
