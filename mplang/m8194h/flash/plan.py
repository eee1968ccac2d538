"""`mpc flash --dry-run`: the download plan of an image, as text (`render_plan`) or data
(`plan_json`); nothing is sent.
"""

from __future__ import annotations

from collections.abc import Callable

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.m8194h.flash.image import FlashImage
from mplang.m8194h.flash.registers import CHIP_INITIALIZED, CHIP_STATE_REGISTER, TRIGGER_REGISTER


def render_plan(image: FlashImage, catalogue: Catalogue | None = None,
                recorded: frozenset[str] = frozenset()) -> str:
    """`mpc flash --dry-run`: every frame that would be written, in order, in hex, with the
    command name and the source line; nothing is sent. Programs in `recorded` (labels such as
    "MP3") are marked: the record says the device holds them, so a real run skips them if the
    device still matches the record."""
    catalogue = catalogue or catalogue_module.load()
    total = sum(len(p.frames) for p in image.programs)
    out = [f"; mpc flash --dry-run: {len(image.programs)} programs, {total} frames, FC16 at "
           f"holding register 8000, word order {image.word_order}"
           + (f", build {image.build_id}" if image.build_id else "")]
    for program in image.programs:
        out.append("")
        slot = f"{program.kind.upper()}{program.slot}"
        mark = "  [recorded on the device: skipped if it still matches]" \
            if slot in recorded else ""
        out.append(f"{program.label}  ({program.where(0) or 'source unknown'})  "
                   f"{len(program.frames)} frames{mark}")
        out += _plan_rows(program.frames, program.where, catalogue)
    if image.init is not None:
        init = image.init
        out.append("")
        out.append(f"INIT  ({init.where(0) or 'source unknown'})  {len(init.frames)} frames, "
                   f"then input register {CHIP_STATE_REGISTER} must read {CHIP_INITIALIZED}")
        out += _plan_rows(init.frames, init.where, catalogue)
    if image.triggers is not None:
        out.append("")
        out.append(f"TRIGGERS  write holding register {TRIGGER_REGISTER} = "
                   f"{int(image.triggers.enabled)} and read it back "
                   f"({len(image.triggers.entries)} channels; the table itself is entered "
                   "with EzMove)")
    return "\n".join(out) + "\n"


def _plan_rows(frames: list[list[int]], where: Callable[[int], str | None],
               catalogue: Catalogue) -> list[str]:
    """One dry-run line per frame: index, command, registers in hex, source place."""
    rows = []
    for index, frame in enumerate(frames):
        command = catalogue.by_code.get(frame[0])
        name = command.short_name if command is not None else "?"
        words = " ".join(f"{w:04X}" for w in frame)
        rows.append(f"  {index:>4}  {name:<20} {words:<44} {where(index) or ''}".rstrip())
    return rows


def plan_json(image: FlashImage, recorded: frozenset[str] = frozenset()) -> dict[str, object]:
    """`mpc flash --dry-run --json`: the same plan as data."""
    plan: dict[str, object] = {
        "dry_run": True, "word_order": image.word_order, "build_id": image.build_id,
        "programs": [{"kind": p.kind, "slot": p.slot, "name": p.name, "source": p.source,
                      "recorded": f"{p.kind.upper()}{p.slot}" in recorded,
                      "frame_lines": p.lines, "frames": p.frames}
                     for p in image.programs]}
    if image.init is not None:
        plan["init"] = {"source": image.init.source, "frame_lines": image.init.lines,
                        "frames": image.init.frames}
    if image.triggers is not None:
        plan["triggers"] = {"register": TRIGGER_REGISTER,
                            "value": int(image.triggers.enabled),
                            "entries": image.triggers.entries}
    return plan
