"""`mpc flash` for the M8194H, as the family face calls it: build (or load) the image of
every device once per distinct source set and word order, then download and verify over
Modbus TCP or RTU, one device or a fleet at once, with the flash record for incremental
flashing. The download itself is `mplang.m8194h.flash`; this module turns a `FlashJob`
into its devices and says what happened through the command's `FlashUI`."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from mplang.family.face import CommandError, FlashJob, FlashTarget, FlashUI
from mplang.ir import catalogue
from mplang.ir.unit import Options
from mplang.m8194h import flash as flashing
from mplang.m8194h.compiler import compile_paths
from mplang.m8194h.flash.lease import LeaseSettings
from mplang.m8194h.flash.manifest import DEFAULT_RANGE, MdRange, parse_range
from mplang.m8194h.modbus import DeviceLink, Endpoint

DEFAULT_TIMEOUT, DEFAULT_RETRIES = 1.0, 3


def flash(job: FlashJob, ui: FlashUI) -> str:
    """Flash every device of the job; the outcome (`FLASH_OUTCOMES`)."""
    images = _Images(job.paths, job.options, ui, job.word_order_fixed)
    record_path = job.record or flashing.default_record_path()
    identity = identity_range(job.identity, job.identity_where)
    lease = LeaseSettings.of(catalogue.load().profile)
    devices: list[flashing.FleetDevice] = []
    for device in job.devices:
        image, rebuild = images.for_target(device)
        endpoint = Endpoint(
            host=device.host, port=device.port, serial=device.serial, baudrate=device.baud,
            parity=device.parity, stopbits=device.stopbits, unit=device.unit,
            timeout=job.timeout if job.timeout is not None else
            device.timeout or job.settings_timeout or DEFAULT_TIMEOUT,
            retries=job.retries if job.retries is not None else _first_int(
                device.retries, job.settings_retries, DEFAULT_RETRIES))
        devices.append(flashing.FleetDevice(device.name, image, endpoint, flashing.FlashOptions(
            set_word_order=job.set_word_order or job.settings_set_word_order,
            rebuild=rebuild, address=device.address(), force=job.force,
            stop_running=job.stop_running, identity=identity, lease=lease,
            wait_lease=job.wait_lease)))
    record = flashing.FlashRecord(record_path)
    if job.dry_run:
        _dry_run(devices, record, job.as_json, ui)
        return "verified"
    for device_job in devices:
        device_job.options = replace(device_job.options, record=record)
    try:
        if not job.fleet:
            return _flash_one(devices[0], job.as_json, ui)
        return _flash_fleet(devices, job.as_json, ui)
    finally:
        record.close()  # the journal of the devices' saves folded into the file, once


def identity_range(identity: str | bool | None, where: str | None) -> MdRange | None:
    """The machine-data range of the build manifest (`mpc flash`, `mpc status`): --identity,
    [flash] identity (`where` names its line), or the default; None for --no-identity /
    `identity = false`."""
    if identity is False:
        return None
    text = identity if isinstance(identity, str) else DEFAULT_RANGE
    try:
        return parse_range(text)
    except ValueError as exc:
        if where:
            raise CommandError("input", f"{where}: {exc}") from None
        raise CommandError("usage", str(exc), "--identity") from None


def _first_int(*values: int | None) -> int:
    return next(v for v in values if v is not None)


@dataclass
class _Images:
    """Builds each distinct set of sources once (per word order), or loads an image JSON."""

    paths: list[Path]
    options: Options
    ui: FlashUI
    fixed_order: bool

    def __post_init__(self) -> None:
        self._cache: dict[tuple[tuple[Path, ...], int | None, str],
                          tuple[flashing.FlashImage,
                                Callable[[int], flashing.FlashImage] | None]] = {}

    def for_target(self, device: FlashTarget) -> tuple[
            flashing.FlashImage, Callable[[int], flashing.FlashImage] | None]:
        if device.image is not None:
            return self._load(device.image, device.word_order), None
        paths = list(device.sources) or self.paths
        if not paths:
            raise CommandError("usage", "nothing to flash: give FILE..., or list sources in "
                               "mpc.toml ([project] sources or the target's own)")
        options = self.options if device.word_order is None \
            else self.options.replace(word_order=device.word_order)
        if device.target is not None:
            options = options.replace(target=device.target)
        key = (tuple(paths), options.word_order, options.target)
        if key not in self._cache:
            self._cache[key] = self._build(paths, options, device.word_order is not None)
        return self._cache[key]

    def _load(self, path: Path, word_order: int | None) -> flashing.FlashImage:
        try:
            image = flashing.load_image(path)
        except OSError as exc:
            raise CommandError("input", f"cannot read {path}: {exc.strerror or exc}") from None
        except flashing.ImageError as exc:
            raise CommandError("input", f"{exc}") from None
        if word_order is not None and word_order != image.word_order:
            raise CommandError("input", f"{path}: the image is built for word order "
                               f"{image.word_order}, its target asks for {word_order}")
        return image

    def _build(self, paths: list[Path], options: Options, target_fixes_order: bool
               ) -> tuple[flashing.FlashImage, Callable[[int], flashing.FlashImage] | None]:
        images = [p for p in paths if p.suffix.lower() == ".json"]
        if images:
            if len(paths) != 1:
                raise CommandError("usage", "give one image JSON, or .mp sources, not both")
            if self.fixed_order and options.word_order is not None:
                raise CommandError("usage", "an image JSON carries its own word order; "
                                   "--word-order is for building .mp sources", "--word-order")
            return self._load(images[0], None), None
        result = compile_paths(paths, options)
        self.ui.checked(result)
        image = flashing.image_from_build(result)
        if self.fixed_order or target_fixes_order:
            return image, None

        def build_for(order: int) -> flashing.FlashImage:
            """Sources without a chosen word order follow the device's: the same build."""
            return flashing.image_from_build(compile_paths(
                paths, options.replace(word_order=order)))
        return image, build_for


def _dry_run(devices: list[flashing.FleetDevice], record: flashing.FlashRecord,
             as_json: bool, ui: FlashUI) -> None:
    plans = []
    for device in devices:
        recorded = record.recorded_slots(device.options.address or "")
        if as_json:
            plan = flashing.plan_json(device.image, recorded)
            plans.append({"device": device.name, **plan} if len(devices) > 1 else plan)
            continue
        if len(devices) > 1:
            ui.out(f"; device {device.name} ({device.endpoint.describe()})\n")
        ui.out(flashing.render_plan(device.image, recorded=recorded))
    if as_json:
        ui.out(json.dumps(plans[0] if len(plans) == 1 else {"devices": plans}) + "\n")


def _flash_one(device: flashing.FleetDevice, as_json: bool, ui: FlashUI) -> str:
    flasher: flashing.Flasher | None = None
    display = ui.progress(lambda: [flasher.report] if flasher else [])
    flasher = flashing.Flasher(device.image, DeviceLink(device.endpoint), device.options,
                               display.say)
    report = display.drive(flasher.run, lambda: flasher.report)
    written, unchanged = report.count("verified"), report.count("unchanged")
    if report.ok:
        kept = f", {unchanged} unchanged" if unchanged else ""
        steps = "".join(text for step, text in ((report.init, ", initial table loaded"),
                                                (report.triggers, ", DI triggering set"))
                        if step is not None)
        display.say(f"{written} program(s) written and verified{kept}{steps} on "
                    f"{report.device}"
                    + (f" (build {report.build_id})" if report.build_id else ""))
    else:
        where = f"{report.where}: " if report.where else ""
        display.say(f"{where}error: {report.error}")
        display.say(f"{written} of {len(report.programs)} program(s) written and verified"
                    + (f", {unchanged} unchanged" if unchanged else ""))
    if as_json:
        ui.out(json.dumps(report.to_json(), indent=1) + "\n")
    return report.outcome


def _flash_fleet(devices: list[flashing.FleetDevice], as_json: bool, ui: FlashUI) -> str:
    fleet: flashing.Fleet | None = None
    display = ui.progress(lambda: fleet.reports if fleet else [])
    fleet = flashing.Fleet(devices, lambda name, text: display.say(f"{name}: {text}"))
    display.drive(fleet.run, lambda: fleet.reports)
    reports = fleet.reports
    for line in fleet_table(devices, reports):
        display.say(line)
    if as_json:
        ui.out(json.dumps({"ok": all(r.ok for r in reports), "devices": [
            {"name": d.name, **r.to_json()} for d, r in zip(devices, reports, strict=True)]},
            indent=1) + "\n")
    failed = {r.outcome for r in reports if not r.ok}
    if not failed:
        return "verified"
    return failed.pop() if len(failed) == 1 else "mixed"


def fleet_table(devices: list[flashing.FleetDevice],
                reports: list[flashing.FlashReport]) -> list[str]:
    """One row per device: name, address, outcome, programs written / unchanged, time, and
    the error where there is one."""
    rows = [("DEVICE", "ADDRESS", "RESULT", "WRITTEN", "UNCHANGED", "SECONDS")]
    for device, result in zip(devices, reports, strict=True):
        outcome = "ok" if result.ok else result.outcome
        rows.append((device.name, device.endpoint.describe(), outcome,
                     str(result.count("verified")), str(result.count("unchanged")),
                     f"{result.seconds:.2f}"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True))
             .rstrip() for row in rows]
    for device, result in zip(devices, reports, strict=True):
        if not result.ok:
            where = f"{result.where}: " if result.where else ""
            lines.append(f"{device.name}: {where}{result.error}")
    return lines
