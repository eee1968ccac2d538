"""What a flash run tells its caller: the outcome of the run (`OUTCOMES`), one result per
program and per INIT/TRIGGERS step, gathered in a `FlashReport`, and the two exceptions that end
a download (`Refused`, `FlashFailure`) on their way into that report.

Success means every program was verified (or, flashing incrementally, recorded as already on
the device). `flash` returns a `FlashReport` with one `ProgramResult` per program whatever
happens; its `outcome` tells the CLI which exit code.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.m8194h.modbus import DeviceException

OUTCOMES = ("verified", "no-device", "rejected", "unverified", "interrupted", "leased")
"""`FlashReport.outcome`: every program verified; the device cannot be reached; the device
refused a program (or cannot take the image); the device did not confirm a download; the link
failed beyond the retries, the device stayed busy, or the run was cancelled; another client
holds the device's download lease (`lease`), or took it during the flash."""


class Refused(Exception):
    """The device refused a frame (any Modbus exception but busy); `cause` is input register
    102 for ILLEGAL FUNCTION, else None."""

    def __init__(self, exception: DeviceException, cause: int | None, reason: str) -> None:
        super().__init__(reason)
        self.code = exception.code
        self.cause = cause


class FlashFailure(Exception):
    """Ends a flash run; `outcome` is one of OUTCOMES, `where` a source file:line or None."""

    def __init__(self, outcome: str, message: str, where: str | None = None) -> None:
        super().__init__(message)
        self.outcome = outcome
        self.where = where


class OtherClient(FlashFailure):
    """Another client downloads at the same time (the device's registers show it): the
    flash names it by the device's lease where it holds one."""

    def __init__(self, message: str) -> None:
        super().__init__("interrupted", message)


@dataclass
class ProgramResult:
    """What happened to one program. `status`: "verified"; "unchanged" (the record says the
    device holds exactly this program: nothing written); "rejected" (the device refused it);
    "unverified" (downloaded, not confirmed); "interrupted" (the link or the user cut the
    download); "pending" (never sent, because an earlier program failed)."""

    kind: str
    slot: int
    name: str | None
    source: str | None
    frames: int
    status: str = "pending"
    downloads: int = 0  # times the create frame was sent
    busy_waits: int = 0
    seconds: float = 0.0
    error: str | None = None
    where: str | None = None
    download_status: list[int] | None = None  # input registers 110-114 after the close

    @property
    def label(self) -> str:
        return f"{self.kind.upper()}{self.slot}" + (f" {self.name}" if self.name else "")

    def to_json(self) -> dict[str, object]:
        return {"kind": self.kind, "slot": self.slot, "name": self.name,
                "source": self.source, "frames": self.frames, "status": self.status,
                "downloads": self.downloads, "busy_waits": self.busy_waits,
                "seconds": round(self.seconds, 4), "error": self.error, "where": self.where,
                "download_status": self.download_status}


@dataclass
class StepResult:
    """The INIT download or the TRIGGERS enable: "pending", "verified", "rejected",
    "unverified" or "interrupted", with the error and its source place."""

    what: str  # "init" | "triggers"
    frames: int
    status: str = "pending"
    seconds: float = 0.0
    error: str | None = None
    where: str | None = None
    detail: str | None = None

    def to_json(self) -> dict[str, object]:
        return {"status": self.status, "frames": self.frames,
                "seconds": round(self.seconds, 4), "error": self.error, "where": self.where,
                "detail": self.detail}


@dataclass
class FlashReport:
    device: str
    word_order: int
    build_id: str | None
    programs: list[ProgramResult]
    init: StepResult | None = None
    triggers: StepResult | None = None
    outcome: str = "verified"
    error: str | None = None
    where: str | None = None
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    frames_planned: int = 0  # frames of the programs to write (known once connected)
    frames_written: int = 0  # frames the device accepted so far (progress displays poll it)
    manifest: dict[str, object] | None = None  # the build manifest in the device's MD

    @property
    def ok(self) -> bool:
        steps = [s for s in (self.init, self.triggers) if s is not None]
        return self.outcome == "verified" and all(p.status in ("verified", "unchanged")
                                                  for p in self.programs) \
            and all(s.status == "verified" for s in steps)

    def count(self, status: str) -> int:
        return sum(1 for p in self.programs if p.status == status)

    def to_json(self) -> dict[str, object]:
        return {"ok": self.ok, "outcome": self.outcome, "device": self.device,
                "word_order": self.word_order, "build_id": self.build_id,
                "error": self.error, "where": self.where, "notes": self.notes,
                "seconds": round(self.seconds, 4), "written": self.count("verified"),
                "unchanged": self.count("unchanged"), "frames_written": self.frames_written,
                "programs": [p.to_json() for p in self.programs],
                **({"init": self.init.to_json()} if self.init is not None else {}),
                **({"triggers": self.triggers.to_json()} if self.triggers is not None
                   else {}),
                **({"manifest": self.manifest} if self.manifest is not None else {})}
