"""Frames of the virtual M8194H's sub-function window, encoded by hand from the catalogue
(no compiler checks, so they can be wrong on purpose), and controllers whose profile makes
the other [download] choices. Shared by the download and refusal tests."""

from __future__ import annotations

from typing import Any

from mplang.ir import catalogue
from mplang.ir.macro import VarRef
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim.controller import VirtualController

CAT = catalogue.load()
ENC = Encoder(CAT, 0)
# the create and close sub-function codes (RS 11787-11792)
CREATE, CREATE_ISR, CLOSE, ISR_CLOSE = 0x0AC9, 0x0ACD, 0x0CCA, 0x0CCE


def rtc(name: str, *values: object) -> list[int]:
    """A real-time frame."""
    command = CAT.rtc_by_short[name]
    return [command.code or 0, *_words(command.name, values)]


def macro(name: str, *values: object) -> list[int]:
    """A macro (download) line."""
    command = CAT.macro_by_short[name]
    return [command.code or 0, *_words(command.name, values)]


def _words(vendor: str, values: tuple[object, ...]) -> list[int]:
    command = CAT.by_vendor[vendor]
    words: list[int] = []
    for param, value in zip(command.params, values, strict=True):
        raw = ENC.var_base + value.index if isinstance(value, VarRef) else int(value)  # type: ignore[call-overload]
        raw &= 0xFFFFFFFF
        words += [raw >> 16, raw & 0xFFFF] if param.wire == 2 else [raw & 0xFFFF]
    return words


def variant(**download: Any) -> VirtualController:
    """A controller whose profile makes the other [download] choice."""
    profile = CAT.profile
    raw = {**profile.raw, "download": {**profile.raw["download"], **download}}
    return VirtualController(CAT.replace(profile=profile.replace(raw=raw)))
