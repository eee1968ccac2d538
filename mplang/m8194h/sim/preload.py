"""Download a build into a virtual controller without Modbus: what `mpc run` and `mpc sim`
do before they start, and what a flash would leave on a device. Kept apart from the
Modbus service so `mpc run` does not load the Modbus stack."""

from __future__ import annotations

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.controller import DeviceBusy, VirtualController

INIT_SETTLE_S = 10.0  # simulated seconds preload allows the init frames to take effect


class ServiceError(Exception):
    """The simulator cannot start as asked; `kind` is "memory" (the macro memory file),
    "transport" (a port that cannot be opened) or "program" (the build does not load: a
    program, the init frames or the trigger table refused)."""

    def __init__(self, message: str, kind: str = "transport") -> None:
        super().__init__(message)
        self.kind = kind


def preload(controller: VirtualController, build: BuildResult) -> None:
    """Download a build into the controller, as `mpc flash` would: the programs, then the
    initial table (image["init"]: its frames go through the sub-function window like a
    Modbus write, and the controller runs until the table is loaded), then the FRnet DI
    trigger table (image["triggers"], which the vendor utility would send), enabled if the
    image says so. Images without "init" or "triggers" load their programs only."""
    for program in build.programs:
        error = controller.load_frames(program.program.kind, program.placement.slot,
                                       program.frames)
        if error is not None:
            raise ServiceError(f"the virtual controller refused {program.program.label}: "
                               f"download error {error.code:#04x} at line {error.line}",
                               "program")
    image = build.image()
    if image.get("init") is not None:
        _preload_init(controller, image["init"])
    if image.get("triggers") is not None:
        _preload_triggers(controller, image["triggers"])


def _preload_init(controller: VirtualController, init: object) -> None:
    """Write the INIT frames at register 8000 and let the device run them (a full FIFO is
    waited out, as a host retries after exception 0x06)."""
    frames = init.get("frames") if isinstance(init, dict) else None
    if not isinstance(frames, list):
        raise ServiceError("image \"init\" must be an object with a \"frames\" list", "program")
    for index, frame in enumerate(frames):
        if not isinstance(frame, list) or not frame or not all(
                isinstance(w, int) and not isinstance(w, bool) and 0 <= w <= 0xFFFF
                for w in frame):
            raise ServiceError(f"init frame {index}: {frame!r} is not a list of 16-bit "
                               "register values", "program")
        while True:
            try:
                cause = controller.write_subfunction(frame)
            except DeviceBusy:  # let the device work off one command time, then retry
                controller.advance(controller.clock + controller.rtc_time)
                continue
            break
        if cause:
            reason = controller.profile.illegal_function_causes.get(cause, "unknown cause")
            raise ServiceError(f"the virtual controller refused init frame {index} "
                               f"{[f'{w:#06x}' for w in frame]}: cause {cause:#04x} "
                               f"({reason})", "program")
    controller.advance(controller.clock + INIT_SETTLE_S, until_idle=True)


def _preload_triggers(controller: VirtualController, triggers: object) -> None:
    if not isinstance(triggers, dict) or not isinstance(triggers.get("enabled", False), bool):
        raise ServiceError("image \"triggers\" must be an object with \"entries\" and a "
                           "true/false \"enabled\"", "program")
    try:
        controller.load_trigger_table(triggers.get("entries", []))
    except ValueError as exc:
        raise ServiceError(f"the trigger table: {exc}", "program") from None
    if triggers.get("enabled", False):
        controller.set_triggering(True)


