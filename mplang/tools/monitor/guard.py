"""What keeps the dashboard safe to leave running beside a machine (docs/monitor.md,
"Security"): which names a request may give in `Host` and `Origin` (an exact list, so a page
whose own name was made to point here, DNS rebinding, is refused), and `Gate`, which bounds
the connections so that half-open ones cannot keep the page out or exhaust the process's
file descriptors.
"""

from __future__ import annotations

import asyncio
import errno
import ipaddress
import re
import sys
from collections.abc import Callable
from typing import Any

from aiohttp import web
from aiohttp.web_protocol import RequestHandler

LOOPBACK_NAMES = ("127.0.0.1", "::1", "localhost")
WILDCARDS = ("0.0.0.0", "::", "")
MAX_CONNECTIONS = 256  # far more than a few pages and scripts need
MIN_CONNECTIONS = 8
MAX_BACKLOG = 128  # aiohttp's own default
PORT_DIGITS = re.compile(r"[1-9][0-9]{0,4}")


def split_host(value: str) -> tuple[str, int | None] | None:
    """`name[:port]` as a Host header or an Origin's authority gives it (IPv6 in brackets,
    or a bare `::1`): the lower-case name without brackets and the port, or None when it is
    not of that form."""
    value = value.strip().lower()
    if value.startswith("["):
        end = value.find("]")
        if end < 0:
            return None
        name, rest = value[1:end], value[end + 1:]
    elif value.count(":") > 1:
        name, rest = value, ""
    else:
        name, colon, port = value.partition(":")
        rest = colon + port
    if not name:
        return None
    if not rest:
        return name, None
    digits = rest[1:]  # ASCII digits in their one spelling: no "08194", no "８１９４"
    if rest[0] != ":" or not PORT_DIGITS.fullmatch(digits) or int(digits) > 65535:
        return None
    return name, int(digits)


def is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class Names:
    """The names this dashboard answers to: 127.0.0.1, ::1, localhost and the address it
    was told to bind, exactly (never a prefix: `127.attacker.example` is a name like any
    other). Bound to a wildcard (0.0.0.0, ::) it is reached through any of this machine's
    addresses, so any IP literal is accepted too; a literal cannot be rebound, a name can."""

    def __init__(self, bind: str, port: int = 0) -> None:
        bound = bind.strip().strip("[]").lower()
        self.names = frozenset((*LOOPBACK_NAMES, bound) if bound not in WILDCARDS
                               else LOOPBACK_NAMES)
        self.any_ip = bound in WILDCARDS
        self.port = port  # the served port, known once the dashboard listens

    def _known(self, name: str) -> bool:
        return name in self.names or (self.any_ip and is_ip(name))

    def host_ok(self, host: str) -> bool:
        """A Host header naming this dashboard, with its port or none."""
        split = split_host(host)
        return split is not None and self._known(split[0]) and split[1] in (None, self.port)

    def origin_ok(self, origin: str) -> bool:
        """An Origin of a page this dashboard served (`http://NAME:PORT`; no port only when
        it is served on 80). `null` and every other scheme are foreign."""
        scheme, sep, authority = origin.strip().lower().partition("://")
        split = split_host(authority) if sep and scheme == "http" else None
        if split is None or not self._known(split[0]):
            return False
        return split[1] == self.port or (split[1] is None and self.port == 80)


def soft_file_limit() -> int | None:
    """The process's open-file limit (RLIMIT_NOFILE, soft), None where there is none to
    stay under (Windows, or unlimited)."""
    if sys.platform == "win32":
        return None
    try:
        import resource
    except ImportError:  # a POSIX system without it: no limit to stay under
        return None
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    return None if soft == resource.RLIM_INFINITY else soft


def backlog_for(soft: int | None) -> int:
    """The listen backlog, which is also how many connections asyncio accepts in one go
    before the Gate hears of any: at most an eighth of the open-file limit."""
    return MAX_BACKLOG if soft is None else max(8, min(MAX_BACKLOG, soft // 8))


def connection_cap(soft: int | None, backlog: int) -> int:
    """How many connections the dashboard keeps open: MAX_CONNECTIONS, or fewer under a low
    open-file limit, leaving a quarter of it (at least 16) to the device link, the files
    the process reads and, in `mpc sim --monitor`, the simulator's own clients, and two
    accept bursts (a burst is accepted, then the oldest are closed, a loop turn later)."""
    if soft is None:
        return MAX_CONNECTIONS
    return max(MIN_CONNECTIONS, min(MAX_CONNECTIONS, soft - max(16, soft // 4) - 2 * backlog))


class Gate:
    """The dashboard's connections, oldest first. Past `cap` open ones, the oldest that has
    not yet sent a whole request is closed to make room (so a flood of half-open
    connections cannot keep the page out; a page's WebSocket is never the one closed), and
    a new one is refused only when every open one is busy. aiohttp's keep-alive timer
    closes a connection that sends no whole request in time. Each kind of trouble is one
    warning line while it lasts, never a traceback."""

    def __init__(self, cap: int, warn: Callable[[str], None]) -> None:
        self.cap = cap
        self.warn = warn
        self.open: set[RequestHandler] = set()
        self.waiting: dict[RequestHandler, None] = {}  # no whole request yet; oldest first
        self.warned: set[str] = set()

    def attach(self, server: web.Server) -> None:
        """Hear of each connection as aiohttp's server does (each connection's handler
        tells it), keeping aiohttp's own bookkeeping."""
        made, lost = server.connection_made, server.connection_lost

        def connection_made(handler: RequestHandler, transport: asyncio.Transport) -> None:
            made(handler, transport)
            self.opened(handler)

        def connection_lost(handler: RequestHandler, exc: BaseException | None = None) -> None:
            lost(handler, exc)
            self.closed(handler)

        server.connection_made = connection_made  # type: ignore[method-assign]
        server.connection_lost = connection_lost  # type: ignore[method-assign]

    def opened(self, handler: RequestHandler) -> None:
        self.open.add(handler)
        self.waiting[handler] = None
        if len(self.open) <= self.cap:
            return
        self._say("limit", f"{len(self.open)} connections to the dashboard, past its limit "
                  f"of {self.cap}: closing the oldest that have sent no request")
        self.shed(self.cap, keep=handler)
        if len(self.open) > self.cap:  # every other one is busy: refuse this one
            self._drop(handler)
            asyncio.get_running_loop().call_soon(handler.force_close)

    def closed(self, handler: RequestHandler) -> None:
        self._drop(handler)
        if len(self.open) <= self.cap // 2:
            self.warned.clear()  # the trouble is over: say it again if it comes back

    def busy(self, handler: RequestHandler) -> None:
        """A whole request arrived on `handler`: it is not idle any more."""
        self.waiting.pop(handler, None)

    def idle(self, handler: RequestHandler) -> None:
        """`handler` answered and waits for the next request (keep-alive)."""
        if handler in self.open:
            self.waiting[handler] = None

    def shed(self, count: int, keep: RequestHandler | None = None) -> None:
        """Close the oldest waiting connections until at most `count` are open."""
        for handler in list(self.waiting):
            if len(self.open) <= count:
                break
            if handler is not keep:
                self._drop(handler)
                handler.force_close()

    def exhausted(self, backlog: int) -> None:
        """The process ran out of file descriptors (accept failed with EMFILE: the limit
        is lower than at the start, or something else holds files): keep fewer connections
        from now on, what the limit leaves now and at most three quarters of those open,
        and close the oldest waiting ones to get there, so the next request (the page's)
        can be accepted."""
        soft = soft_file_limit()
        self.cap = max(MIN_CONNECTIONS, min(self.cap, connection_cap(soft, backlog),
                                            len(self.open) - len(self.open) // 4))
        limit = f" (open-file limit {soft})" if soft is not None else ""
        self._say("files", f"out of file descriptors{limit}: the dashboard now keeps at "
                  f"most {self.cap} connections (raise the limit with ulimit -n)")
        self.shed(self.cap)

    def loop_errors(self, previous: Callable[[asyncio.AbstractEventLoop, dict[str, Any]],
                                             object] | None, backlog: int
                    ) -> Callable[[asyncio.AbstractEventLoop, dict[str, Any]], None]:
        """An event-loop exception handler: running out of file descriptors on accept
        (which asyncio would log with a traceback on every retry) is `exhausted`; anything
        else goes where it went before."""

        def handle(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
            exc = context.get("exception")
            if isinstance(exc, OSError) and exc.errno in (errno.EMFILE, errno.ENFILE):
                self.exhausted(backlog)
            elif previous is not None:
                previous(loop, context)
            else:
                loop.default_exception_handler(context)

        return handle

    def _drop(self, handler: RequestHandler) -> None:
        self.open.discard(handler)
        self.waiting.pop(handler, None)

    def _say(self, kind: str, text: str) -> None:
        if kind not in self.warned:
            self.warned.add(kind)
            self.warn(text)
