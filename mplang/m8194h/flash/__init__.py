"""`mpc flash` as a library call: download an image into one device and verify every program.

`flash(image, endpoint, options, progress)` flashes one device, `flash_fleet(devices, progress)`
many at once. The package is split along its responsibilities:

- `image`: the image to download (`FlashImage`), from a build or a checked image JSON;
- `plan`: the dry run (`render_plan`, `plan_json`);
- `registers`: the device registers the download protocol reads and writes;
- `record`: the incremental-flashing record (`FlashRecord`);
- `report`: outcomes, per-program results (`FlashReport`) and the errors that end a run;
- `flasher`: the download protocol of one device (`Flasher`, `flash`, `FlashOptions`);
- `fleet`: many devices at once (`Fleet`, `flash_fleet`).

Every name is re-exported here, so callers import from `mplang.m8194h.flash`.
"""

from __future__ import annotations

from mplang.m8194h.flash.flasher import (
    BUSY_PAUSE_FIRST_S,
    BUSY_PAUSE_MAX_S,
    INIT_POLL_S,
    INIT_TIMEOUT_S,
    Flasher,
    FlashOptions,
    flash,
)
from mplang.m8194h.flash.fleet import Fleet, FleetDevice, flash_fleet
from mplang.m8194h.flash.image import (
    FlashImage,
    FlashInit,
    FlashProgram,
    FlashTriggers,
    ImageError,
    image_from_build,
    image_from_json,
    load_image,
)
from mplang.m8194h.flash.plan import plan_json, render_plan
from mplang.m8194h.flash.record import RECORD_FORMAT, FlashRecord, default_record_path
from mplang.m8194h.flash.registers import (
    CAUSE_REGISTER,
    CHIP_INITIALIZED,
    CHIP_LOADING,
    CHIP_STATE_REGISTER,
    DEVICE_BUSY,
    DPRAM_FULL,
    IDENTITY_COUNT,
    IDENTITY_FIRST,
    ILLEGAL_FUNCTION,
    STATE_REGISTER,
    STATES,
    STATUS_COUNT,
    STATUS_FIRST,
    TRIGGER_REGISTER,
    WORD_ORDER_REGISTER,
)
from mplang.m8194h.flash.report import (
    OUTCOMES,
    FlashFailure,
    FlashReport,
    ProgramResult,
    Refused,
    StepResult,
)

__all__ = [
    "BUSY_PAUSE_FIRST_S",
    "BUSY_PAUSE_MAX_S",
    "CAUSE_REGISTER",
    "CHIP_INITIALIZED",
    "CHIP_LOADING",
    "CHIP_STATE_REGISTER",
    "DEVICE_BUSY",
    "DPRAM_FULL",
    "IDENTITY_COUNT",
    "IDENTITY_FIRST",
    "ILLEGAL_FUNCTION",
    "INIT_POLL_S",
    "INIT_TIMEOUT_S",
    "OUTCOMES",
    "RECORD_FORMAT",
    "STATES",
    "STATE_REGISTER",
    "STATUS_COUNT",
    "STATUS_FIRST",
    "TRIGGER_REGISTER",
    "WORD_ORDER_REGISTER",
    "FlashFailure",
    "FlashImage",
    "FlashInit",
    "FlashOptions",
    "FlashProgram",
    "FlashRecord",
    "FlashReport",
    "FlashTriggers",
    "Flasher",
    "Fleet",
    "FleetDevice",
    "ImageError",
    "ProgramResult",
    "Refused",
    "StepResult",
    "default_record_path",
    "flash",
    "flash_fleet",
    "image_from_build",
    "image_from_json",
    "load_image",
    "plan_json",
    "render_plan",
]
