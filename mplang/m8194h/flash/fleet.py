"""Fleets (`flash_fleet`): one `Flasher` per device, concurrently; devices that share a serial
port (one RS-485 bus) take turns, because one line carries one request at a time.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.m8194h.flash.flasher import Flasher, FlashOptions
from mplang.m8194h.flash.image import FlashImage
from mplang.m8194h.flash.report import FlashReport
from mplang.m8194h.modbus import DeviceLink, Endpoint


@dataclass
class FleetDevice:
    """One device of a fleet: its name (from the fleet file), image, endpoint and options."""

    name: str
    image: FlashImage
    endpoint: Endpoint
    options: FlashOptions = FlashOptions()  # frozen: safe to share


def _bus(endpoint: Endpoint) -> str | None:
    """Devices on the same serial port share one bus and must take turns."""
    return os.path.realpath(endpoint.serial) if endpoint.serial is not None else None


class Fleet:
    """Flash many devices at once: one Flasher per device, all started together, except that
    devices on one serial bus go one after another. A device that fails (or a bug met while
    flashing it) ends that device's run only. `flashers` exist from the start, so a display
    can poll their reports while `run` goes on."""

    def __init__(self, devices: Sequence[FleetDevice],
                 progress: Callable[[str, str], None] | None = None,
                 catalogue: Catalogue | None = None) -> None:
        catalogue = catalogue or catalogue_module.load()
        self.devices = list(devices)
        say: Callable[[str, str], None] = progress or (lambda _name, _text: None)

        def teller(name: str) -> Callable[[str], None]:
            return lambda text: say(name, text)

        self.flashers = [Flasher(device.image, DeviceLink(device.endpoint), device.options,
                                 teller(device.name), catalogue) for device in self.devices]

    @property
    def reports(self) -> list[FlashReport]:
        return [flasher.report for flasher in self.flashers]

    async def _one(self, flasher: Flasher) -> None:
        try:
            await flasher.run()
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a bug must not take the other devices down with it
            flasher.report.outcome = "interrupted"
            flasher.report.error = f"internal error in mpc: {type(exc).__name__}: {exc}"

    async def _in_turn(self, flashers: list[Flasher]) -> None:
        for flasher in flashers:
            await self._one(flasher)

    async def run(self) -> list[FlashReport]:
        lanes: dict[object, list[Flasher]] = {}
        for index, (device, flasher) in enumerate(zip(self.devices, self.flashers,
                                                      strict=True)):
            lanes.setdefault(_bus(device.endpoint) or index, []).append(flasher)
        tasks = [asyncio.ensure_future(self._in_turn(lane)) for lane in lanes.values()]
        try:
            await asyncio.gather(*tasks)
        except asyncio.CancelledError:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            for report in self.reports:
                if report.outcome == "verified" and not report.ok:
                    report.outcome = "interrupted"
                    report.error = report.error or "interrupted before this device was flashed"
            raise
        return self.reports


async def flash_fleet(devices: Sequence[FleetDevice],
                      progress: Callable[[str, str], None] | None = None) -> list[FlashReport]:
    """Flash every device of `devices` (see `Fleet`); one report per device, in order."""
    return await Fleet(devices, progress).run()
