"""`mpc flash` for the CSIM, as the family face calls it: the one program of the build sent
with DLP, listed back with ULP and compared, then saved with SAVE P
(`mplang.csim.download.download`), over the device's serial line. Every way that can fail
(`DownloadError.kind`) ends in the outcome of the M8194H failure it resembles."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from mplang.csim.build import TARGETS, CsimProgram, FamilyBuild, check_native
from mplang.csim.compile import compile_mp
from mplang.csim.download import DownloadError, download
from mplang.family.face import CommandError, FlashJob, FlashTarget, FlashUI
from mplang.ir.unit import Options

DEFAULT_TIMEOUT = 1.0
DOWNLOAD_OUTCOME = {"port": "no-port", "no-answer": "no-device", "device-error": "rejected",
                    "program": "rejected", "echo": "unverified", "reply": "unverified",
                    "mismatch": "unverified"}
"""DownloadError.kind -> outcome: the port cannot be opened, nothing answers, the device or
the program refuses a line, the answers do not confirm the download."""


def flash(job: FlashJob, ui: FlashUI) -> str:
    """Flash the job's one CSIM (a fleet of CSIMs is refused before this is called)."""
    device = job.devices[0]
    modbus = [key for key, value in (("unit", device.unit != 1), ("word-order",
              device.word_order is not None), ("retries", device.retries is not None)) if value]
    if modbus and device.span is not None:
        raise CommandError("usage", f"{device.span.file}:{device.span.line}: "
                           f"[targets.{device.name}] sets {', '.join(modbus)}: M8194H "
                           "settings, and the target is CSIM")
    paths = [device.image] if device.image is not None else list(device.sources) or job.paths
    images = [p for p in paths if p.suffix.lower() == ".json"]
    if images:
        raise CommandError("usage", f"{images[0]}: an image JSON is an M8194H download image; "
                           "a CSIM program is flashed from a .csim listing or .mp sources")
    if not paths:
        raise CommandError("usage", "nothing to flash: give FILE..., or list sources in "
                           "mpc.toml ([project] sources or the target's own)")
    program = build_program(paths, job.options, ui.checked, "flash")
    if job.dry_run:
        _dry_run(program, job.as_json, ui)
        return "verified"
    if device.serial is None:
        raise CommandError("usage", "give the CSIM's serial port: --serial PORT (or --to NAME "
                           "of an mpc.toml target with serial = \"PORT\")")
    timeout = job.timeout if job.timeout is not None \
        else device.timeout or job.settings_timeout or DEFAULT_TIMEOUT
    return _download(program, device, timeout, job.as_json, ui)


def build_program(paths: list[Path], options: Options,
                  checked: Callable[[FamilyBuild], None], verb: str) -> CsimProgram:
    """The one program a CSIM holds, built from a .csim listing or .mp sources (`checked`
    reports the diagnostics and ends the command on errors); `verb` names the command in
    the refusal of sources that make several."""
    native = all(p.suffix.lower() == ".csim" for p in paths)
    build: FamilyBuild = check_native(paths) if native \
        else compile_mp(paths, options, TARGETS[0])
    checked(build)
    programs = [p for p in build.programs if isinstance(p, CsimProgram)]
    if len(programs) != 1:
        names = ", ".join(f"{p.name} ({p.source})" for p in programs)
        raise CommandError("usage", f"a CSIM holds one program, and these sources make "
                           f"{len(programs)} ({names}): {verb} one .csim listing, or .mp "
                           "sources (they compile to one program)")
    return programs[0]


def _dry_run(program: CsimProgram, as_json: bool, ui: FlashUI) -> None:
    """The exchange that would happen: DLP, every line, the empty line, ULP, SAVE P."""
    if as_json:
        ui.out(json.dumps({"dry_run": True, "target": "csim", "program": program.name,
                           "source": program.source, "lines": program.lines}, indent=1) + "\n")
        return
    ui.out(f"; CSIM program {program.name} ({program.source}): {len(program.lines)} "
           "line(s); sent after DLP, closed by an empty line, listed back with ULP and "
           "compared, then SAVE P\n")
    for address, text in enumerate(program.lines):
        ui.out(f"{address:04d}  {text}\n")


def _download(program: CsimProgram, device: FlashTarget, timeout: float, as_json: bool,
              ui: FlashUI) -> str:
    """Download, verify and save; the outcome."""
    assert device.serial is not None
    port = device.serial
    line = f"{device.baud} 8{device.parity}{device.stopbits}"
    ui.say(f"CSIM on {port} ({line}): program {program.name} ({program.source}), "
           f"{len(program.lines)} line(s)")
    summary: dict[str, object] = {"device": port, "target": "csim", "program": program.name,
                                  "source": program.source, "lines": len(program.lines)}
    try:
        done = download(program, port, device.baud, timeout, save=True,
                        parity=device.parity, stopbits=device.stopbits)
    except DownloadError as exc:
        where = program.source if exc.line is None or exc.line >= len(program.origins) \
            else f"{program.origins[exc.line].file}:{program.origins[exc.line].line}"
        ui.say(f"{where}: error: {exc.message}")
        outcome = DOWNLOAD_OUTCOME[exc.kind]
        if as_json:
            ui.out(json.dumps({"ok": False, "outcome": outcome, "kind": exc.kind,
                               "error": exc.message, "where": where, **summary,
                               "verified": False, "saved": False}, indent=1) + "\n")
        return outcome
    ui.say(f"{done.lines} line(s) of {program.name} downloaded, listed back identical and "
           f"saved (SAVE P) on {port} ({done.elapsed_s:.2f} s)")
    if as_json:
        ui.out(json.dumps({"ok": True, "outcome": "verified", "kind": None, "error": None,
                           "where": None, **summary, "verified": done.verified,
                           "saved": done.saved, "seconds": round(done.elapsed_s, 3)},
                          indent=1) + "\n")
    return "verified"
