"""`mpc flash` for the other controller families: a CSIM program over its serial line, and
the reason a FATEK FBs-PLC table cannot be flashed.

A CSIM holds one program. It is built like `mpc build` builds it (a `.csim` listing, or
`.mp` sources compiled for `--target csim`), then `mplang.csim.download.download` sends it
with DLP, lists it back with ULP, compares, and saves it with SAVE P. Every way that can fail
(`DownloadError.kind`) has the exit code of the M8194H failure it resembles.
"""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Mapping
from dataclasses import dataclass

import click

from mplang.cli.common import (
    EXIT_NO_DEVICE,
    EXIT_REJECTED,
    EXIT_TRANSPORT,
    EXIT_UNVERIFIED,
    BuildSetup,
    report,
)
from mplang.cli.families import Selection, refuse_options
from mplang.csim import CsimProgram
from mplang.csim.download import DownloadError, download
from mplang.tools.project import Target

DOWNLOAD_EXIT = {"port": EXIT_TRANSPORT, "no-answer": EXIT_NO_DEVICE,
                 "device-error": EXIT_REJECTED, "program": EXIT_REJECTED,
                 "echo": EXIT_UNVERIFIED, "reply": EXIT_UNVERIFIED, "mismatch": EXIT_UNVERIFIED}
"""DownloadError.kind -> exit code: the port cannot be opened (6), nothing answers (7), the
device or the program refuses a line (8), the answers do not confirm the download (9)."""
DOWNLOAD_OUTCOME = {"port": "no-port", "no-answer": "no-device", "device-error": "rejected",
                    "program": "rejected", "echo": "unverified", "reply": "unverified",
                    "mismatch": "unverified"}


@dataclass(frozen=True)
class FlashRequest:
    """What the command line asked of `mpc flash`, beyond the build and the device."""

    tcp_given: bool
    dry_run: bool
    as_json: bool
    timeout: float
    m8194h_options: Mapping[str, bool]  # option -> given on the command line


def flash_family(selection: Selection, setup: BuildSetup, device: Target,
                 request: FlashRequest) -> None:
    """Flash `device` with the program of `selection` (a family build), or refuse."""
    family = selection.family
    refuse_transport(selection, request.tcp_given)
    if family is not importlib.import_module("mplang.csim"):
        raise click.UsageError(f"mpc flash has no downloader for {selection.describe}")
    refuse_options(selection, request.m8194h_options, "FLASH_OPTIONS")
    modbus = [key for key, value in (("unit", device.unit != 1), ("word-order",
              device.word_order is not None), ("retries", device.retries is not None)) if value]
    if modbus and device.span is not None:
        raise click.UsageError(f"{device.span.file}:{device.span.line}: [targets.{device.name}] "
                               f"sets {', '.join(modbus)}: M8194H settings, and the target is "
                               f"{selection.describe}")
    images = [p for p in selection.paths if p.suffix.lower() == ".json"]
    if images:
        raise click.UsageError(f"{images[0]}: an image JSON is an M8194H download image; a "
                               "CSIM program is flashed from a .csim listing or .mp sources")
    if not selection.paths:
        raise click.UsageError("nothing to flash: give FILE..., or list sources in mpc.toml "
                               "([project] sources or the target's own)")
    build = selection.build(setup.options)
    code = report(build, setup.werror)
    if code:
        sys.exit(code)
    programs = [p for p in build.programs if isinstance(p, CsimProgram)]
    if len(programs) != 1:
        names = ", ".join(f"{p.name} ({p.source})" for p in programs)
        raise click.UsageError(f"a CSIM holds one program, and these sources make "
                               f"{len(programs)} ({names}): flash one .csim listing, or .mp "
                               "sources (they compile to one program)")
    program = programs[0]
    if request.dry_run:
        _dry_run(program, request.as_json)
        return
    if device.serial is None:
        raise click.UsageError("give the CSIM's serial port: --serial PORT (or --to NAME of "
                               "an mpc.toml target with serial = \"PORT\")")
    _download(program, device, request)


def refuse_transport(selection: Selection, tcp_given: bool) -> None:
    """A usage error if the family cannot be flashed at all (FATEK: why, and what to do
    instead), or not over Modbus TCP (CSIM)."""
    family = selection.family
    if not family.TRANSPORTS:
        target = selection.target or family.TARGETS[0]
        raise click.UsageError(
            f"{selection.describe} programs cannot be flashed: {family.NO_TRANSPORT}. Write "
            f"the register table with `mpc build --target {target} --format table` (or the "
            f"listing with --format fbs) and enter it in WinProladder")
    if tcp_given and "tcp" not in family.TRANSPORTS:
        raise click.UsageError(f"a {family.TITLE} is reached over RS232: give --serial PORT "
                               "(--tcp is Modbus TCP, for the ET-M8194H)")


def _dry_run(program: CsimProgram, as_json: bool) -> None:
    """The exchange that would happen: DLP, every line, the empty line, ULP, SAVE P."""
    if as_json:
        click.echo(json.dumps({"dry_run": True, "target": "csim", "program": program.name,
                               "source": program.source, "lines": program.lines}, indent=1))
        return
    click.echo(f"; CSIM program {program.name} ({program.source}): {len(program.lines)} "
               "line(s); sent after DLP, closed by an empty line, listed back with ULP and "
               "compared, then SAVE P")
    for address, text in enumerate(program.lines):
        click.echo(f"{address:04d}  {text}")


def _download(program: CsimProgram, device: Target, request: FlashRequest) -> None:
    """Download, verify and save; exit with the code of the failure's kind."""
    assert device.serial is not None
    port = device.serial
    line = f"{device.baud} 8{device.parity}{device.stopbits}"
    click.echo(f"mpc flash: CSIM on {port} ({line}): program {program.name} "
               f"({program.source}), {len(program.lines)} line(s)", err=True)
    summary: dict[str, object] = {"device": port, "target": "csim", "program": program.name,
                                  "source": program.source, "lines": len(program.lines)}
    try:
        done = download(program, port, device.baud, request.timeout, save=True,
                        parity=device.parity, stopbits=device.stopbits)
    except DownloadError as exc:
        where = program.source if exc.line is None or exc.line >= len(program.origins) \
            else f"{program.origins[exc.line].file}:{program.origins[exc.line].line}"
        click.echo(f"mpc flash: {where}: error: {exc.message}", err=True)
        if request.as_json:
            click.echo(json.dumps({"ok": False, "outcome": DOWNLOAD_OUTCOME[exc.kind],
                                   "kind": exc.kind, "error": exc.message, "where": where,
                                   **summary,
                                   "verified": False, "saved": False}, indent=1))
        sys.exit(DOWNLOAD_EXIT[exc.kind])
    click.echo(f"mpc flash: {done.lines} line(s) of {program.name} downloaded, listed back "
               f"identical and saved (SAVE P) on {port} ({done.elapsed_s:.2f} s)", err=True)
    if request.as_json:
        click.echo(json.dumps({"ok": True, "outcome": "verified", "kind": None, "error": None,
                               "where": None, **summary, "verified": done.verified,
                               "saved": done.saved, "seconds": round(done.elapsed_s, 3)},
                              indent=1))
