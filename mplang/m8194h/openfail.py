"""What pymodbus does not keep: the exception met while a client connected or a server
started listening. pymodbus 3.16 logs it and answers False, so `mplang.m8194h.modbus` wraps
the one coroutine through which pymodbus opens a socket or a serial port (`call_create`)
and reads the reason from what it recorded (`mplang.family.linkfail`)."""

from __future__ import annotations

from typing import Any


class OpenFailure(OSError):
    """A server could not listen, or a client could not connect: `reason` says why in words
    (`mplang.family.linkfail`)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def recording(protocol: Any) -> list[BaseException]:
    """pymodbus logs why a connect or listen failed and returns False: keep the exception
    its transport met (the last one) for the message. `call_create` is the one place where
    pymodbus 3.16 opens a socket or serial port."""
    failures: list[BaseException] = []
    create = protocol.call_create

    async def recorded() -> Any:
        try:
            return await create()
        except BaseException as exc:
            failures.append(exc)
            raise

    protocol.call_create = recorded
    return failures
