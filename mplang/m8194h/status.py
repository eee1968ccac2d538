"""`mpc status` for the M8194H: what a controller holds and does, read over Modbus TCP or RTU
with nothing but reads. The device cannot read a stored program back, so what it holds is
what its build manifest in machine data says (`mplang.m8194h.flash.manifest`), trusted while
the device's download status (input registers 110-114) is still the one the manifest
recorded. Given sources, an image or a project, each slot is compared with what `mpc flash`
would write: `in sync`, `differs`, `missing` (the manifest does not list it), `extra` (the
manifest lists a slot the build does not have).

`read_status` is the library call (a dict, the `--json` output); `status` is the family
face's entry (`Family.status_device`).
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mplang.family.face import CommandError, FlashTarget, StatusJob, StatusUI
from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.scope import Variable
from mplang.m8194h import flash as flashing
from mplang.m8194h.compiler import compile_paths
from mplang.m8194h.encode import join32
from mplang.m8194h.flash import manifest as mf
from mplang.m8194h.flash.registers import (
    CALL_REGISTER,
    IDENTITY_COUNT,
    IDENTITY_FIRST,
    STATE_REGISTER,
    STATE_SPAN,
    WORD_ORDER_REGISTER,
    state_name,
)
from mplang.m8194h.flashing import identity_range
from mplang.m8194h.modbus import DeviceException, DeviceLink, Endpoint, LinkError

AXES = ("X", "Y", "Z", "U")
AXIS_FIRST, AXIS_COUNT = 16, 46  # input 16-19 DI status, 20-23 error code, 24 running,
# 25 emergency, 26-33 LP, 34-41 EP, 42-49 CV, 50-57 CA, 58-61 stop status (1 stopped)
SIGNAL_FIRST = 88  # input 88-91: the DI signal word of each axis (appendix table 10)
VAR_BASE = 300  # holding register of VAR0 (300 + 2n)
OUTCOMES = ("in-sync", "out-of-sync", "no-device")
LAMP_LETTERS = {"limit_plus": "L+", "limit_minus": "L-", "near_home": "NH", "home": "HM",
                "index": "IX", "alarm": "AL", "inpos": "IP", "emg": "EMG"}
"""The lamps `mpc status` prints per axis, and their short names (the profile's [lamps])."""


def lamp_bits(catalogue: Catalogue) -> dict[str, tuple[int, int]]:
    """The profile's [lamps]: name -> (bit of the DI status word, the value that means on)."""
    table = catalogue.profile.raw["lamps"]
    return {name: (int(value[0]), int(value[1])) for name, value in table.items()
            if isinstance(value, list)}


def lamps(word: int, bits: dict[str, tuple[int, int]]) -> dict[str, bool]:
    """Which inputs of one axis are on, from its DI status word (input 16 + axis)."""
    return {name: (word >> bit & 1) == on for name, (bit, on) in bits.items()}


async def read_status(link: DeviceLink, identity: mf.MdRange | None,
                      image: flashing.FlashImage | None = None,
                      variables: list[Variable] | None = None,
                      catalogue: Catalogue | None = None) -> dict[str, Any]:
    """Everything `mpc status` shows, as data; LinkError / DeviceException when the device
    cannot be read. `image` is compared slot by slot with the manifest."""
    (order,) = await link.read_holding(WORD_ORDER_REGISTER, 1)
    ident = await link.read_input(IDENTITY_FIRST, IDENTITY_COUNT)
    span = await link.read_input(STATE_REGISTER, STATE_SPAN)
    (running,) = await link.read_holding(CALL_REGISTER, 1)
    axes_regs = await link.read_input(AXIS_FIRST, AXIS_COUNT)
    signals = await link.read_input(SIGNAL_FIRST, len(AXES))
    catalogue = catalogue or catalogue_module.load()
    profile = catalogue.profile
    bits = lamp_bits(catalogue)
    download, execution = span[10:15], span[15:20]
    out: dict[str, Any] = {
        "device": link.endpoint.describe(),
        "identity": {"module_id": ident[0], "rsm_firmware": join32(ident[1:3], order, False),
                     "i8094h_firmware": join32(ident[3:5], order, False)},
        "word_order": order,
        "state": {"value": span[0], "name": state_name(span[0]), "i8094h_state": span[1],
                  "cause": span[2]},
        "download_status": _five(download),
        "running": {"mp": running, "top": axes_regs[24 - AXIS_FIRST]},
        "execution_error": {**_five(execution), "text": None if not execution[4] else
                            _execution_text(profile.raw.get("execution_errors", {}),
                                            execution[4])},
        "axes": [_axis(axes_regs, signals, n, order, bits) for n in range(len(AXES))],
    }
    manifest: mf.Manifest | None = None
    if identity is None:
        out["manifest"] = None
    else:
        try:
            manifest = await mf.read_manifest(link, identity, order)
            out["manifest"] = {"range": str(identity), **mf.to_json(manifest),
                               "current": span[0] == 0 and list(manifest.status) == download}
        except mf.ManifestError as exc:
            out["manifest"] = {"range": str(identity), "error": str(exc)}
        except DeviceException as exc:  # a device that refuses its machine data
            out["manifest"] = {"range": str(identity), "error": f"cannot be read: {exc}"}
    if variables:
        out["variables"] = [{"name": v.name, "var": v.index,
                             "value": join32(await link.read_holding(VAR_BASE + 2 * v.index, 2),
                                             order)} for v in variables]
    if image is not None:
        out["build_id"] = image.build_id
        out["slots"] = compare(manifest, image)
        current = bool(manifest is not None and out["manifest"].get("current"))
        out["in_sync"] = current and all(s["status"] == "in sync" for s in out["slots"])
    return out


def _five(values: list[int]) -> dict[str, int]:
    mp_no, isr_no, command, line, error = values
    return {"mp": mp_no, "isr": isr_no, "command": command, "line": line, "error": error}


def _execution_text(table: dict[str, Any], code: int) -> str:
    """The profile's words for an execution error code (its keys are written 0x01 ...)."""
    for key, text in table.items():
        try:
            if int(key, 0) == code:
                return str(text)
        except ValueError:
            continue
    return "unknown execution error"


def _axis(regs: list[int], signals: list[int], n: int, order: int,
          bits: dict[str, tuple[int, int]]) -> dict[str, Any]:
    def pair(first: int) -> int:
        at = first - AXIS_FIRST + 2 * n
        return join32(regs[at:at + 2], order)
    stopped = regs[58 - AXIS_FIRST + n] == 1
    return {"axis": AXES[n], "lp": pair(26), "ep": pair(34), "cv": pair(42),
            "state": "stopped" if stopped else "moving", "di_status": regs[n],
            "di_signal": signals[n], "error_code": regs[4 + n],
            "lamps": lamps(regs[n], bits)}


def compare(manifest: mf.Manifest | None, image: flashing.FlashImage) -> list[dict[str, Any]]:
    """Per slot, what the device holds by its manifest against what the image would write,
    in image order, then the manifest's extra slots. Without a readable manifest nothing is
    known of what the device holds (programs downloaded by another tool, or preloaded with
    `mpc sim FILE...`): every slot is `unknown`, not `missing`."""
    held = manifest.by_slot() if manifest is not None else {}
    rows: list[dict[str, Any]] = []
    for program in image.programs:
        mine = program.content_hash(image.word_order)[:mf.HASH_BYTES * 2]
        there = held.pop(program.slot_label, None)
        status = "unknown" if manifest is None else "missing" if there is None else \
            "in sync" if there.hash == mine else "differs"
        rows.append({"slot": program.slot_label, "name": program.name or "", "status": status,
                     "device_name": there.name if there is not None else None})
    rows += [{"slot": label, "name": "", "status": "extra", "device_name": p.name}
             for label, p in held.items()]
    return rows


def render(data: dict[str, Any]) -> str:
    """The text `mpc status` prints."""
    ident, state = data["identity"], data["state"]
    lines = [f"device      {data['device']}",
             f"identity    module id {ident['module_id']:#04x}, RSM firmware "
             f"{ident['rsm_firmware']:#010x}, i-8094H firmware {ident['i8094h_firmware']:#010x}",
             f"word order  {data['word_order']}",
             f"state       {state['name']} (input 100 = {state['value']}, i-8094H state "
             f"{state['i8094h_state']}, last cause {state['cause']:#04x})"]
    d = data["download_status"]
    lines.append(f"download    MP{d['mp']} ISR{d['isr']} command {d['command']:#06x} line "
                 f"{d['line']} error {d['error']:#04x}")
    run = data["running"]
    top = f" (input 24: program {run['top']} runs now)" if run["top"] != run["mp"] else ""
    lines.append("running     " + (f"MP{run['mp']}{top}" if run["mp"] else
                                   f"ISR{run['top']}" if run["top"] else "nothing"))
    e = data["execution_error"]
    lines.append("errors      " + ("none" if not e["error"] else
                                   f"{e['error']:#04x} ({e['text']}) in MP{e['mp']} ISR{e['isr']} "
                                   f"line {e['line']}"))
    lines += _render_manifest(data.get("manifest"))
    if "slots" in data:
        unknown = all(row["status"] == "unknown" for row in data["slots"])
        lines.append(f"slots       against build {data['build_id'] or '(no id)'}: "
                     + ("in sync" if data["in_sync"] else
                        "unknown: no build manifest to compare with (the programs were not "
                        "downloaded by mpc flash)" if unknown else "out of sync"))
        for row in data["slots"]:
            name = row["name"] or row["device_name"] or ""
            lines.append(f"  {row['status']:<9} {row['slot']:<6} {name}".rstrip())
    lines.append("axes        lamps: L+/L- limits, NH near home, HM home, IX index, AL alarm, "
                 "IP in position, EMG emergency")
    for axis in data["axes"]:
        lines.append(f"  {axis['axis']}  LP {axis['lp']:>11}  EP {axis['ep']:>11}  CV "
                     f"{axis['cv']:>8}  {axis['state']:<7}  {_lamp_text(axis['lamps'])}")
    if data.get("variables"):
        lines.append("variables")
        for var in data["variables"]:
            lines.append(f"  {var['name']} (VAR{var['var']}) = {var['value']}")
    return "\n".join(lines) + "\n"


def _lamp_text(on: dict[str, bool]) -> str:
    """The lamps of one axis that are on, by short name ('-' for none)."""
    lit = [short for name, short in LAMP_LETTERS.items() if on.get(name)]
    return " ".join(lit) or "-"


def _render_manifest(manifest: dict[str, Any] | None) -> list[str]:
    if manifest is None:
        return ["manifest    not read (--no-identity)"]
    if "error" in manifest:
        return [f"manifest    {manifest['range']}: {manifest['error']}"]
    at = datetime.fromtimestamp(manifest["flashed_at"], UTC).isoformat(timespec="seconds")
    lines = [f"manifest    build {manifest['build_id'] or '(no id)'}, flashed {at} by mpc "
             f"{manifest['tool_version']} ({manifest['range']})"]
    if not manifest["current"]:
        lines.append("            the download status changed since (input registers "
                     "110-114): a program may have been downloaded by something else")
    lines += [f"  {p['slot']:<6} {p['name']}".rstrip() for p in manifest["programs"]]
    return lines


def endpoint_of(device: FlashTarget, timeout: float, retries: int) -> Endpoint:
    """Where a status read goes: the device's address and line, the job's patience."""
    return Endpoint(host=device.host, port=device.port, serial=device.serial,
                    baudrate=device.baud, parity=device.parity, stopbits=device.stopbits,
                    unit=device.unit, timeout=timeout, retries=retries)


Builder = Callable[[int], tuple[flashing.FlashImage | None, list[Variable]]]
"""Given the device's word order, what `mpc flash` would write there and its variables."""


async def probe(endpoint: Endpoint, identity: mf.MdRange | None, build: Builder
                ) -> dict[str, Any] | str:
    """Read one device (`read_status`, compared with `build`'s image); the reason in one line
    when it cannot be reached or read."""
    link = DeviceLink(endpoint)
    try:
        await link.open()
        (order,) = await link.read_holding(WORD_ORDER_REGISTER, 1)
        image, variables = build(order)
        return await read_status(link, identity, image, variables)
    except LinkError as exc:
        return str(exc)
    except DeviceException as exc:
        return f"{endpoint.describe()}: {exc}"
    finally:
        link.close()


def status(job: StatusJob, ui: StatusUI) -> str:
    """The family face's `status_device` for one device: read it, compare it with the build
    if one is given, print it; one of `OUTCOMES`."""
    identity = identity_range(job.identity, job.identity_where)
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    endpoint = endpoint_of(job.device, job.timeout, job.retries)
    builds = Builds(job, ui)
    data = asyncio.run(probe(endpoint, identity, lambda order: builds.get(job.device, order)))
    if isinstance(data, str):
        ui.say(f"error: no device: {data}")
        return "no-device"
    ui.out(json.dumps(data, indent=1) + "\n" if job.as_json else render(data))
    if "in_sync" in data and not data["in_sync"]:
        return "out-of-sync"
    return "in-sync"


class Builds:
    """What `mpc flash` would write into each device (built for the device's word order
    unless one was chosen), each distinct build made once, and the build's declared
    variables; nothing without sources."""

    def __init__(self, job: StatusJob, ui: StatusUI) -> None:
        self.job, self.ui = job, ui
        self._made: dict[tuple[object, ...], tuple[flashing.FlashImage | None,
                                                   list[Variable]]] = {}

    def get(self, device: FlashTarget, order: int
            ) -> tuple[flashing.FlashImage | None, list[Variable]]:
        job = self.job
        paths = [device.image] if device.image is not None else \
            list(device.sources) or job.paths
        if not paths:
            return None, []
        fixed = job.word_order_fixed or device.word_order is not None
        chosen = device.word_order if device.word_order is not None else job.options.word_order
        key = (tuple(paths), chosen if fixed else order, device.target)
        if key not in self._made:
            self._made[key] = self._make(paths, device, chosen if fixed else order)
        return self._made[key]

    def _make(self, paths: list[Path], device: FlashTarget, order: int | None
              ) -> tuple[flashing.FlashImage | None, list[Variable]]:
        images = [p for p in paths if p.suffix.lower() == ".json"]
        if images:
            if len(paths) != 1:
                raise CommandError("usage", "give one image JSON, or .mp sources, not both")
            return _load(images[0]), []
        options = self.job.options.replace(word_order=order)
        if device.target is not None:
            options = options.replace(target=device.target)
        result = compile_paths(paths, options)
        self.ui.checked(result)
        return flashing.image_from_build(result), list(result.variables)


def _load(path: Path) -> flashing.FlashImage:
    try:
        return flashing.load_image(path)
    except OSError as exc:
        raise CommandError("input", f"cannot read {path}: {exc.strerror or exc}") from None
    except flashing.ImageError as exc:
        raise CommandError("input", f"{exc}") from None
