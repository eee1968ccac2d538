"""Downloading a CSIM program over a serial line (pyserial) and verifying it.

The exchange follows the protocol reading of stdlib/csim/device.toml [protocol]: `DLP`, one
program line at a time (each echoed and answered OK), the empty line that ends edit mode,
then `ULP` to list the program back, compared line by line with what was sent. Anything
else is an error with a reason: no answer within the timeout, an echo that differs from the
line sent, an ERR reply (with the device's text), a reply that is neither OK nor ERR, or a
listing that differs. A download never reports success unless the listing matched.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.csim import profile as profile_module
from mplang.csim.build import CsimProgram
from mplang.family.linkfail import serial_reason

UNSOLICITED_LIMIT = 1000
"""Lines a running program may print (OUT) before the echo of a query, before the query
counts as unanswered: a program printing without pause must not hold a host for ever."""


class DownloadError(Exception):
    """The download failed. kind: port, no-answer, echo, device-error, reply, mismatch,
    program. `line`: the index of the program line concerned, where there is one (so a
    caller can name its source line)."""

    def __init__(self, kind: str, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.kind = kind
        self.message = message
        self.line = line


@dataclass
class DownloadReport:
    port: str
    lines: int
    verified: bool
    saved: bool
    elapsed_s: float
    listing: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, object]:
        return {"port": self.port, "lines": self.lines, "verified": self.verified,
                "saved": self.saved, "elapsed_s": round(self.elapsed_s, 3)}


def open_port(port: str, baud: int, parity: str, stopbits: int, timeout: float
              ) -> serial.Serial:
    """Open the CSIM's serial line: the one place where a CSIM host opens it, so every
    failure says why (no such serial device, permission denied, in use: see
    `mplang.family.linkfail`) as DownloadError "port"."""
    try:
        return serial.serial_for_url(port, baudrate=baud, parity=parity, stopbits=stopbits,
                                     timeout=timeout, write_timeout=timeout)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise DownloadError("port", f"cannot open serial port {port} (CSIM RS232, {baud} "
                            f"8{parity}{stopbits}): {serial_reason(exc)}") from None


class SerialLine:
    """One serial port speaking the CSIM protocol: a line sent, its echo checked, the data
    lines until OK (DownloadError for ERR, silence or a reply of another shape)."""

    def __init__(self, port: serial.Serial, name: str) -> None:
        self.port = port
        self.name = name
        protocol = profile_module.load().section("protocol")
        self.end_in = str(protocol["line_end_in"]).encode()
        self.end_out = str(protocol["line_end_out"]).encode()
        self.echo = bool(protocol["echo"])
        self.ok = str(protocol["ok"])
        self.error_prefix = str(protocol["error_prefix"]) + " "
        self.unsolicited: list[str] = []  # lines a running program sent before an echo

    def read_line(self, after: str) -> str:
        raw = self.port.read_until(self.end_out)
        if not raw.endswith(self.end_out):
            got = f" (got {raw.decode('ascii', 'replace')!r} so far)" if raw else ""
            raise DownloadError("no-answer", f"no answer from the device on {self.name} "
                                f"within {self.port.timeout:g} s after sending {after!r}{got}")
        try:
            return str(raw[: -len(self.end_out)].decode("ascii"))
        except UnicodeDecodeError:
            raise DownloadError("reply", f"garbled reply to {after!r}: {raw!r}") from None

    def send(self, text: str, answers: bool = False) -> list[str]:
        """Send one line; check the echo; return the data lines once the status is OK (only
        ULP, and a line sent with `answers` (a query), may have data lines). With `answers`
        the lines a running program prints before the echo are set aside (`unsolicited`)."""
        self.port.write(text.encode("ascii") + self.end_in)
        self.port.flush()
        if self.echo:
            echoed = self.read_line(text)
            skipped = 0
            while echoed != text and answers and skipped < UNSOLICITED_LIMIT:
                self.unsolicited.append(echoed)  # what a running program printed (OUT)
                skipped += 1
                echoed = self.read_line(text)
            if echoed != text:
                raise DownloadError("echo", f"wrong echo: sent {text!r}, the device echoed "
                                    f"{echoed!r}")
        data: list[str] = []
        while True:
            reply = self.read_line(text)
            if reply == self.ok:
                return data
            if reply.startswith(self.error_prefix):
                raise DownloadError("device-error", f"the device refused {text!r}: {reply}")
            if text != "ULP" and not answers:
                raise DownloadError("reply", f"unexpected reply to {text!r}: {reply!r} "
                                    f"(expected {self.ok} or {self.error_prefix.strip()} ...)")
            data.append(reply)


def download(program: CsimProgram | list[str], port: str, baud: int = 9600,
             timeout: float = 2.0, *, save: bool = False, parity: str = "N",
             stopbits: int = 1) -> DownloadReport:
    """Send a program with DLP, list it back with ULP and compare; with `save`, SAVE P.
    `baud`, `parity` (N, E, O) and `stopbits` set the line (8 data bits; the manual names
    no line settings). Raises DownloadError (never returns without a verified listing)."""
    lines = program.lines if isinstance(program, CsimProgram) else list(program)
    for number, text in enumerate(lines):
        if not text.strip() or "\r" in text or "\n" in text or not text.isascii():
            raise DownloadError("program", f"line {number} {text!r} cannot be sent: program "
                                "lines are non-empty single lines of ASCII text", number)
    started = time.monotonic()
    link = open_port(port, baud, parity, stopbits, timeout)
    try:
        link.reset_input_buffer()
        line = SerialLine(link, port)
        try:
            line.send("DLP")
            for number, text in enumerate(lines):
                try:
                    line.send(text)
                except DownloadError as exc:
                    exc.line = number
                    raise
            line.send("")
            listing = line.send("ULP")
        except serial.SerialTimeoutException:
            raise DownloadError("no-answer", f"the device on {port} does not take data "
                                f"within {timeout:g} s") from None
        except (serial.SerialException, OSError) as exc:
            raise DownloadError("port", f"{port}: {exc}") from None
        if listing != lines:
            raise DownloadError("mismatch", *_difference(lines, listing))
        if save:
            line.send("SAVE P")
    finally:
        link.close()
    return DownloadReport(port, len(lines), True, save, time.monotonic() - started, listing)


def _difference(sent: list[str], listed: list[str]) -> tuple[str, int | None]:
    for index, (a, b) in enumerate(zip(sent, listed, strict=False)):
        if a != b:
            return f"the device lists line {index} as {b!r}, but {a!r} was sent", index
    return f"the device lists {len(listed)} lines, but {len(sent)} were sent", None
