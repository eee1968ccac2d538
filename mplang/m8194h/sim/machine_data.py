"""Machine data of the virtual M8194H: MD0..MD2047 (manual 3.19), kept in non-volatile memory.

MD0-1023 hold longs, MD1024-2047 IEEE 754 single floats (RS 2518, 2602; 0x43A0D333 is 321.65,
RS 2640-2641). Each is one 32-bit word, stored raw so that whatever a host writes through the
holding registers 3000 + 2n reads back bit for bit. Three ways reach it: the holding registers
(`mplang.m8194h.sim.registers`), the sub-function RSM_WRITE_MD 0x0A27 (`subfunction`), and
Python (`VirtualController.md`: `read`, `write`, `word`, `set_word`), which is how a tool
stores data there before serving. The `mpc sim --memory` file keeps it (`to_json`,
`from_json`); memory files written before MD existed load with every MD 0.
"""

from __future__ import annotations

import math
import struct
from typing import TYPE_CHECKING

from mplang.m8194h.encode import join32

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController

PARAMETER_OUT_OF_RANGE = 0x02  # register 102: "Parameter value is NOT within defined range"
JSON_KEY = "machine_data"


def float_bits(value: float) -> int:
    """The single-precision word of `value` (rounded to float32, as the device stores it)."""
    try:
        return int(struct.unpack(">I", struct.pack(">f", value))[0])
    except OverflowError:
        raise ValueError(f"{value} is outside the float range of machine data") from None


def bits_float(word: int) -> float:
    return float(struct.unpack(">f", struct.pack(">I", word & 0xFFFFFFFF))[0])


def shortest_float(word: int) -> float:
    """The shortest decimal that is the same float32 as `word` (321.65, not 321.6499938964844),
    so a memory file shows what was written."""
    value = bits_float(word)
    for digits in range(1, 10):
        short = float(f"{value:.{digits}g}")
        if float_bits(short) == word:
            return short
    return value


class MachineData:
    """MD0..MD2047 of one controller. Every change counts as a non-volatile one, so `mpc sim
    --memory` saves the file."""

    def __init__(self, controller: VirtualController) -> None:
        self.vc = controller
        raw = controller.profile.raw["machine_data"]
        self.count = int(raw["count"])
        self.first_float = int(raw["first_float"])
        self.holding_base = int(raw["holding_base"])
        self.code = controller.catalogue.by_vendor["RSM_WRITE_MD"].code
        self.words = [0] * self.count

    # ------------------------------------------------------------------- Python API
    def is_float(self, n: int) -> bool:
        self._check(n)
        return n >= self.first_float

    def read(self, n: int) -> int | float:
        """MDn: a signed long (MD0-1023) or a float (MD1024-2047)."""
        word = self.word(n)
        if n >= self.first_float:
            return bits_float(word)
        return word - (1 << 32) if word & 0x80000000 else word

    def write(self, n: int, value: int | float) -> None:
        """Set MDn. A long MD takes an int in the signed 32-bit range; a float MD takes any
        finite number (or an int), rounded to single precision as the device stores it."""
        self.set_word(n, self._word_of(n, value))

    def _word_of(self, n: int, value: object) -> int:
        if self.is_float(n):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                    not math.isfinite(value):
                raise ValueError(f"MD{n} holds a float, not {value!r}")
            return float_bits(float(value))
        if isinstance(value, bool) or not isinstance(value, int) or \
                not -(1 << 31) <= value < (1 << 31):
            raise ValueError(f"MD{n} holds a long (-2147483648..2147483647), not {value!r}")
        return value & 0xFFFFFFFF

    def word(self, n: int) -> int:
        """MDn's raw 32-bit word (unsigned), as the holding registers carry it."""
        self._check(n)
        return self.words[n]

    def set_word(self, n: int, word: int) -> None:
        self._check(n)
        if not 0 <= word <= 0xFFFFFFFF:
            raise ValueError(f"MD{n}: a word is 0..0xFFFFFFFF, not {word}")
        if self.words[n] != word:
            self.words[n] = word
            self.vc.memory_version += 1  # non-volatile: `mpc sim --memory` saves it

    def _check(self, n: int) -> None:
        if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n < self.count:
            raise ValueError(f"machine data are MD0..MD{self.count - 1}, not MD{n}")

    # -------------------------------------------------------------- sub-function
    def owns(self, frame: list[int]) -> bool:
        """Whether `frame` is an RSM_WRITE_MD to carry out now: outside a download (inside
        one it is a real-time command in a macro, which the download refuses)."""
        return len(frame) == 7 and frame[0] == self.code and self.vc.state == "ready"

    def subfunction(self, frame: list[int]) -> int:
        """RSM_WRITE_MD: mdNo, ldata, fdata, each two registers in the present word order
        (RS 2613-2650). Returns 0 or the register-102 cause of the refusal."""
        order = self.vc.word_order
        number = join32(frame[1:3], order)
        if not 0 <= number < self.count:
            self.vc.log.append(f"{self.vc.clock:.4f} s: RSM_WRITE_MD refused: no MD{number}")
            return PARAMETER_OUT_OF_RANGE
        # a long MD takes ldata, a float MD the bits of fdata (0x43A0D333 = 321.65)
        word = join32(frame[5:7] if number >= self.first_float else frame[3:5], order,
                      signed=False)
        self.set_word(number, word)
        self.vc.log.append(f"{self.vc.clock:.4f} s: RSM_WRITE_MD MD{number} = "
                           f"{self.read(number)}")
        return 0

    # ---------------------------------------------------------------- memory file
    def to_json(self) -> dict[str, int | float | str]:
        """The MDs that are not 0, as {"MDn": value}: longs as integers, floats as the
        shortest decimal of the same float32, a NaN or infinity as its word ("0x7fc00000")."""
        out: dict[str, int | float | str] = {}
        for n, word in enumerate(self.words):
            if not word:
                continue
            value = self.read(n)
            if isinstance(value, float) and not math.isfinite(value):
                out[f"MD{n}"] = f"{word:#010x}"
            elif isinstance(value, float):
                out[f"MD{n}"] = shortest_float(word)
            else:
                out[f"MD{n}"] = value
        return out

    def from_json(self, data: object) -> None:
        """Power on with saved machine data (all of it: MDs the file omits are 0). Raises
        ValueError naming the entry that is not an MD value; nothing changes then."""
        if not isinstance(data, dict):
            raise ValueError(f"\"{JSON_KEY}\" must be an object of \"MDn\": value")
        words = [0] * self.count
        for key, value in data.items():
            name = str(key)
            if not (name.startswith("MD") and name[2:].isdigit()) or \
                    not 0 <= int(name[2:]) < self.count:
                raise ValueError(f"{JSON_KEY}: {name!r} is not MD0..MD{self.count - 1}")
            n = int(name[2:])
            if isinstance(value, str) and n >= self.first_float:
                try:
                    word = int(value, 16)
                except ValueError:
                    raise ValueError(f"{JSON_KEY}.{name}: {value!r} is not a hex word") from None
                if not 0 <= word <= 0xFFFFFFFF:
                    raise ValueError(f"{JSON_KEY}.{name}: {value!r} is not a 32-bit word")
                words[n] = word
                continue
            try:
                words[n] = self._word_of(n, value)
            except ValueError as exc:
                raise ValueError(f"{JSON_KEY}.{name}: {exc}") from None
        if words != self.words:
            self.words = words
            self.vc.memory_version += 1
