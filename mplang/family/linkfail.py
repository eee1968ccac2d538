"""Why a connection, a listening port or a serial device could not be opened, in words.

Every transport of every family (Modbus TCP and RTU clients and servers, the CSIM's RS232
line) hands the exception its library met to one of these functions, so that `mpc flash`,
`mpc status` and `mpc sim` say the same reason for the same failure: "connection refused",
"no such host", "no answer (timed out)", "no such serial device", "permission denied",
"port already in use". The operating system's error numbers (errno, getaddrinfo's EAI_*)
decide; pyserial's SerialException carries the errno of the failed open(), so it needs no
import of pyserial here.
"""

from __future__ import annotations

import asyncio
import errno
import socket

TIMED_OUT = "no answer (timed out)"

_NETWORK = {
    errno.ECONNREFUSED: "connection refused (nothing listens on that port)",
    errno.ETIMEDOUT: TIMED_OUT,
    errno.EHOSTUNREACH: "no route to host",
    errno.ENETUNREACH: "network unreachable",
    errno.ECONNRESET: "connection reset by the peer",
    errno.EADDRNOTAVAIL: "address not available",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied (a firewall?)",
}
_LISTEN = {
    errno.EADDRINUSE: "port already in use (another mpc sim or server listens there)",
    errno.EACCES: "permission denied (ports below 1024 need privileges)",
    errno.EPERM: "permission denied (ports below 1024 need privileges)",
    errno.EADDRNOTAVAIL: "not an address of this machine",
}
_SERIAL = {
    errno.ENOENT: "no such serial device",
    errno.ENODEV: "no such serial device",
    errno.ENXIO: "no such serial device (nothing is attached to it)",
    errno.EACCES: "permission denied (is the user in the dialout group?)",
    errno.EPERM: "permission denied (is the user in the dialout group?)",
    errno.EBUSY: "in use by another program",
    errno.EAGAIN: "in use by another program (it holds the port's lock)",
    errno.ENOTTY: "not a serial device",
    errno.EISDIR: "not a serial device (a directory)",
    errno.EINVAL: "not a serial device",
}


def _number(exc: BaseException) -> int | None:
    """The errno of `exc` or of the OSError it was raised from (pyserial, asyncio)."""
    seen: BaseException | None = exc
    while seen is not None:
        code = getattr(seen, "errno", None)
        if isinstance(code, int):
            return code
        if seen.args and isinstance(seen.args[0], int):  # termios.error: (errno, text)
            return int(seen.args[0])
        seen = seen.__cause__ or seen.__context__
    return None


def _host(exc: socket.gaierror) -> str:
    if exc.errno == socket.EAI_AGAIN:
        return "no such host (the name lookup failed: no DNS answer)"
    if exc.errno == socket.EAI_NONAME or exc.errno == getattr(socket, "EAI_NODATA", None):
        return "no such host"
    return f"no such host ({exc.strerror})"


def _plain(exc: BaseException) -> str:
    text = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    return str(text)


def connect_reason(exc: BaseException | None) -> str:
    """Why a TCP connection could not be made (None or a cancelled wait: it timed out)."""
    if exc is None or isinstance(exc, (TimeoutError, asyncio.CancelledError)):
        return TIMED_OUT
    if isinstance(exc, socket.gaierror):
        return _host(exc)
    code = _number(exc)
    return _NETWORK.get(code, _plain(exc)) if code is not None else _plain(exc)


def listen_reason(exc: BaseException | None) -> str:
    """Why a server could not listen on a TCP address."""
    if isinstance(exc, socket.gaierror):
        return _host(exc)
    if exc is None:
        return "the address cannot be bound"
    code = _number(exc)
    return _LISTEN.get(code, _plain(exc)) if code is not None else _plain(exc)


def serial_reason(exc: BaseException | None) -> str:
    """Why a serial device could not be opened (pyserial's or the system's error)."""
    if exc is None:
        return "it cannot be opened"
    code = _number(exc)
    if code is not None and code in _SERIAL:
        return _SERIAL[code]
    text = _plain(exc)
    return text.split(": ", 1)[1] if text.startswith("could not open port") and ": " in text \
        else text
