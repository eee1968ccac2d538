"""What a Modbus link to one device is, in plain Python: where the device is (`Endpoint`),
how a request can fail (`LinkError` and its kinds, `DeviceException` with the exception
names), and the repeat pauses (`backoff`). `mplang.m8194h.modbus`, the only pymodbus user,
re-exports them; they live here so that file stays one transport."""

from __future__ import annotations

from dataclasses import dataclass

MODBUS_EXCEPTIONS = {
    0x01: "ILLEGAL FUNCTION", 0x02: "ILLEGAL DATA ADDRESS", 0x03: "ILLEGAL DATA VALUE",
    0x04: "SLAVE DEVICE FAILURE", 0x05: "ACKNOWLEDGE", 0x06: "SLAVE DEVICE BUSY",
    0x08: "MEMORY PARITY ERROR", 0x0A: "GATEWAY PATH UNAVAILABLE",
    0x0B: "GATEWAY TARGET DEVICE FAILED TO RESPOND",
}

class LinkError(Exception):
    """The link failed: whether the device carried the request out is unknown."""


class LinkUnavailable(LinkError):
    """The device cannot be reached: connection refused, no route, no such serial port."""


class LinkTimeout(LinkError):
    """No answer within the timeout, or an answer that belongs to another request."""


class LinkLost(LinkError):
    """The connection closed while a request was outstanding."""


class DeviceException(Exception):
    """The device refused a request with a Modbus exception response, so it did not carry it
    out. `code` is the Modbus exception code (0x01 ILLEGAL FUNCTION ... 0x06 BUSY)."""

    def __init__(self, code: int, function_code: int, address: int) -> None:
        self.code = code
        self.function_code = function_code
        self.address = address
        super().__init__(f"Modbus exception {code:#04x} ({self.name}) to function "
                         f"{function_code} at register {address}")

    @property
    def name(self) -> str:
        return MODBUS_EXCEPTIONS.get(self.code, "unknown exception")


@dataclass(frozen=True)
class Endpoint:
    """Where and how to reach one device: Modbus TCP (`host`) or RTU (`serial`), one of them.
    The ET-M8194H answers as unit 1 (its card number); an RS-M8194H as its slave address."""

    host: str | None = None
    port: int = 502
    serial: str | None = None
    baudrate: int = 115200
    parity: str = "N"
    stopbits: int = 1
    unit: int = 1
    timeout: float = 1.0  # seconds per answer; the ET manual suggests 1-2 s (ET 788)
    retries: int = 3  # repeats of an idempotent request, and reconnection attempts

    def __post_init__(self) -> None:
        if (self.host is None) == (self.serial is None):
            raise ValueError("an endpoint is either Modbus TCP (host) or Modbus RTU (serial)")

    def describe(self) -> str:
        if self.host is not None:
            return f"Modbus TCP {self.host}:{self.port} unit {self.unit}"
        return (f"Modbus RTU {self.serial} unit {self.unit} "
                f"({self.baudrate} 8{self.parity}{self.stopbits})")


def backoff(attempt: int, ceiling: float = 1.0, first: float = 0.05) -> float:
    """The pause before repeat `attempt` (1, 2, ...): doubling from `first` up to `ceiling`,
    so a glitch costs little and a device that restarts gets time."""
    return float(min(ceiling, first * 2 ** (attempt - 1)))
