"""The dashboard's web server: polls a `LiveDevice` (20 times a second by default) and serves
the page, `GET /api/state`, the WebSocket `/ws` (one message per poll: the state and the
path points added since the last message) and, with `allow_write`, the write endpoints
(`POST /api/call`, `/api/var`, `/api/stop`, `/api/emergency-stop`, `/api/clear-emergency`);
without it they answer 403. A device that cannot be read is a state like any other
(`connected` false, `error` saying why), never an exception out of the poll.

Safe by construction (docs/monitor.md, "Security"; the checks are `guard`): every request
must name this dashboard in `Host` (an exact list: 421 otherwise) and, when it carries an
`Origin`, be from a page this dashboard served (403); a write must also carry the
session's token (`X-MPC-Token`, 403 without it), which only the page and a same-origin
`GET /api/session` give out. Connections are bounded (`guard.Gate`) and a request's
headers and body must arrive in time.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import hmac
import json
import secrets
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

from mplang.family.face import CommandError, DeviceUnreachable, LiveDevice
from mplang.lang.limits import load_json
from mplang.tools.monitor.guard import (
    Gate,
    Names,
    backlog_for,
    connection_cap,
    soft_file_limit,
)

PERIOD_S = 0.05  # 20 polls a second while the device answers
RETRY_S = 0.5  # between attempts while it does not
PATH_LIMIT = 100_000  # path points kept; the oldest half goes when it is reached
ASSETS = {"monitor.js": "text/javascript", "monitor.css": "text/css",
          "favicon.svg": "image/svg+xml"}
ACTIONS = {"call": "call", "var": "set_var", "stop": "stop",
           "emergency-stop": "emergency_stop", "clear-emergency": "clear_emergency"}
LOOPBACK = ("127.0.0.1", "localhost", "::1")
TOKEN_HEADER = "X-MPC-Token"
TOKEN_SLOT = "__MPC_TOKEN__"  # where index.html receives the session's token
HEADER_TIMEOUT_S = 10.0  # a connection's next request must arrive whole within this
BODY_TIMEOUT_S = 10.0  # a write's body, once its headers are in
SECURITY_HEADERS = {
    "X-Content-Type-Options": "nosniff",  # no answer of ours runs as another page's script
    "X-Frame-Options": "DENY",  # no other page frames the buttons (clickjacking)
    "Content-Security-Policy": "frame-ancestors 'none'",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",  # the page carries the session's token
}


class MonitorError(Exception):
    """The dashboard cannot be served (its port is taken, the address is not this
    machine's)."""


def _asset(name: str) -> bytes:
    return (resources.files("mplang.tools.monitor") / "assets" / name).read_bytes()


class Monitor:
    """The polled state of one device, its tool path, and the clients watching it."""

    def __init__(self, device: LiveDevice, *, allow_write: bool, period: float = PERIOD_S,
                 title: str = "", names: Names, gate: Gate) -> None:
        self.device = device
        self.allow_write = allow_write
        self.period = period
        self.title = title
        self.names = names  # what Host and Origin may name
        self.gate = gate  # the connections, bounded
        self.token = secrets.token_urlsafe(32)  # this process's; see `write`
        self.lock = asyncio.Lock()  # one request at a time on the device's link
        self.state: dict[str, Any] = {"connected": False, "error": "connecting",
                                      "seq": 0, "updated": None, "write": allow_write,
                                      "title": title, "path_points": 0}
        self.path: list[list[int]] = []  # [x, y, z] logic positions, in order
        self.path_base = 0  # the absolute index of path[0]
        self.tick = asyncio.Event()
        self.polls = 0
        self.failures = 0

    # ------------------------------------------------------------------ polling
    async def poll_forever(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            started = loop.time()
            try:
                async with self.lock:
                    data = await self.device.read()
            except DeviceUnreachable as exc:
                self.failures += 1
                self.publish(None, f"device unreachable: {exc}; reconnecting")
                await asyncio.sleep(RETRY_S)
                continue
            except Exception as exc:  # a fault of the reader: shown, and the poll goes on
                self.failures += 1
                self.device.close()
                self.publish(None, f"cannot read the device (an mpc fault, please report "
                             f"it): {exc!r}; reconnecting")
                await asyncio.sleep(RETRY_S)
                continue
            self.publish(data, None)
            await asyncio.sleep(max(0.0, self.period - (loop.time() - started)))

    def publish(self, data: dict[str, Any] | None, error: str | None) -> None:
        """A new state: the device's (data), or the last one marked unreachable."""
        self.polls += 1
        if data is None:
            state = {k: v for k, v in self.state.items() if k not in ("connected", "error")}
        else:
            state = data
            axes = data.get("axes") or []
            if len(axes) >= 3:
                point = [int(axes[0]["lp"]), int(axes[1]["lp"]), int(axes[2]["lp"])]
                if not self.path or self.path[-1] != point:
                    self.path.append(point)
                    if len(self.path) >= PATH_LIMIT:
                        drop = PATH_LIMIT // 2
                        del self.path[:drop]
                        self.path_base += drop
        self.state = {**state, "connected": data is not None, "error": error,
                      "seq": self.polls, "updated": time.time(), "write": self.allow_write,
                      "title": self.title, "path_points": self.path_base + len(self.path)}
        tick, self.tick = self.tick, asyncio.Event()
        tick.set()

    def points_from(self, index: int) -> tuple[int, list[list[int]]]:
        """The path points from absolute `index` on (from the oldest kept one, if that
        one is gone): where they start, and the points."""
        start = max(index, self.path_base)
        return start, self.path[start - self.path_base:]

    # ------------------------------------------------------------------ handlers
    async def page(self, _request: web.Request) -> web.Response:
        """The page, carrying the session's token (only a page of this origin can read
        it)."""
        body = _asset("index.html").replace(TOKEN_SLOT.encode(), self.token.encode())
        return web.Response(body=body, content_type="text/html", charset="utf-8")

    async def favicon(self, _request: web.Request) -> web.Response:
        return web.Response(body=_asset("favicon.svg"), content_type="image/svg+xml")

    async def session(self, _request: web.Request) -> web.Response:
        """The token for a script (curl, a host program) that drives the writes; a page of
        another origin is refused before it gets here, and could not read the answer."""
        return web.json_response({"token": self.token, "header": TOKEN_HEADER,
                                  "write": self.allow_write})

    async def asset(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in ASSETS:
            raise web.HTTPNotFound(text=f"no asset {name}")
        return web.Response(body=_asset(name), content_type=ASSETS[name], charset="utf-8")

    async def api_state(self, request: web.Request) -> web.Response:
        state = dict(self.state)
        if request.query.get("path") == "1":
            state["path"] = self.points_from(0)[1]
        return web.json_response(state)

    async def websocket(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=10)
        await ws.prepare(request)
        sent = 0
        reader = asyncio.ensure_future(self._drain(ws))
        try:
            while not ws.closed and not reader.done():
                start, points = self.points_from(sent)
                sent = start + len(points)
                await ws.send_str(json.dumps({"state": self.state, "path_from": start,
                                              "path": points}))
                waiter = asyncio.ensure_future(self.tick.wait())
                await asyncio.wait((waiter, reader), return_when=asyncio.FIRST_COMPLETED)
                waiter.cancel()
        except (ConnectionResetError, RuntimeError):
            pass  # the page went away between two messages
        finally:
            reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await reader
            await ws.close()
        return ws

    @staticmethod
    async def _drain(ws: web.WebSocketResponse) -> None:
        """Read (and drop) what the page sends, until it closes the socket."""
        async for message in ws:
            if message.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                break

    async def write(self, request: web.Request) -> web.Response:
        """One write to the device. Host and Origin were checked by `_guard`; here the
        session's token, then the body (which must arrive within BODY_TIMEOUT_S)."""
        if not self.allow_write:
            return web.json_response({"error": "read-only: writing needs mpc monitor "
                                      "--allow-write"}, status=403)
        sent = request.headers.get(TOKEN_HEADER, "").encode("utf-8", "surrogateescape")
        if not hmac.compare_digest(sent, self.token.encode()):  # in constant time
            return web.json_response({"error": f"refused: a write needs this session's "
                                      f"token in {TOKEN_HEADER} (the page sends it; a "
                                      "script gets it from GET /api/session)"}, status=403)
        if request.content_type != "application/json":
            return web.json_response({"error": "send the request as application/json"},
                                     status=415)
        try:
            text = await asyncio.wait_for(request.text(), BODY_TIMEOUT_S) \
                if request.can_read_body else ""
        except TimeoutError:
            response = web.json_response({"error": f"the body did not arrive within "
                                          f"{BODY_TIMEOUT_S:g} s"}, status=408)
            response.force_close()
            return response
        try:  # nesting bounded before decoding: a hostile body is a 400, never a 500
            args = load_json(text) if text else {}
        except ValueError:
            return web.json_response({"error": "the body is not JSON"}, status=400)
        if not isinstance(args, dict):
            return web.json_response({"error": "the body must be a JSON object"}, status=400)
        action = ACTIONS[request.match_info["action"]]
        try:
            async with self.lock:
                done = await self.device.act(action, args)
        except CommandError as exc:  # 409: a flash holds the device's download lease
            return web.json_response({"error": str(exc)},
                                     status=409 if exc.kind == "leased" else 400)
        except DeviceUnreachable as exc:
            return web.json_response({"error": f"device unreachable: {exc}"}, status=503)
        return web.json_response({"ok": True, "done": done})

    @web.middleware
    async def _guard(self, request: web.Request,
                     handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
                     ) -> web.StreamResponse:
        """Every route: the request must name this dashboard in Host (a page of another
        site whose name was made to point here, DNS rebinding, names its own: 421) and,
        when it has an Origin (browsers send one with every write and WebSocket
        handshake), come from a page this dashboard served (403). The connection is busy
        (not to be shed by the Gate) until it is answered."""
        self.gate.busy(request.protocol)
        try:
            host = request.headers.get("Host", "")
            if not self.names.host_ok(host):
                return web.json_response({"error": f"refused: the dashboard does not answer "
                                          f"to the host name {host!r}"}, status=421)
            origin = request.headers.get("Origin")
            if origin is not None and not self.names.origin_ok(origin):
                return web.json_response({"error": f"refused: a request from a page of "
                                          f"{origin}, not of this dashboard"}, status=403)
            return await handler(request)
        finally:
            self.gate.idle(request.protocol)

    @staticmethod
    async def _headers(_request: web.Request, response: web.StreamResponse) -> None:
        response.headers.update(SECURITY_HEADERS)

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._guard])
        app.on_response_prepare.append(self._headers)
        app.router.add_get("/", self.page)
        app.router.add_get("/favicon.ico", self.favicon)
        app.router.add_get("/assets/{name}", self.asset)
        app.router.add_get("/api/state", self.api_state)
        app.router.add_get("/api/session", self.session)
        app.router.add_get("/ws", self.websocket)
        app.router.add_post("/api/{action:" + "|".join(ACTIONS) + "}", self.write)
        return app


def warn(text: str) -> None:
    """One warning line on standard error (the dashboard's trouble that is not an exit)."""
    print(f"mpc monitor: warning: {text}", file=sys.stderr, flush=True)


@contextlib.asynccontextmanager
async def serving(device: LiveDevice, host: str, port: int, *, allow_write: bool,
                  title: str = "", period: float = PERIOD_S,
                  say_warning: Callable[[str], None] = warn) -> AsyncIterator[
                      tuple[Monitor, str]]:
    """Serve the dashboard of `device` on host:port (0: any free port) while the block
    runs; yields the monitor and its URL. MonitorError when it cannot listen."""
    soft = soft_file_limit()
    backlog = backlog_for(soft)
    names, gate = Names(host), Gate(connection_cap(soft, backlog), say_warning)
    monitor = Monitor(device, allow_write=allow_write, period=period, title=title,
                      names=names, gate=gate)
    runner = web.AppRunner(monitor.app(), access_log=None, handle_signals=False,
                           keepalive_timeout=HEADER_TIMEOUT_S)
    await runner.setup()
    assert runner.server is not None
    gate.attach(runner.server)
    try:
        await web.TCPSite(runner, host, port, shutdown_timeout=0.5, backlog=backlog).start()
    except OSError as exc:
        await runner.cleanup()
        device.close()
        reason = "the port is in use (another mpc monitor? choose one with --port)" \
            if exc.errno == errno.EADDRINUSE else exc.strerror or str(exc)
        raise MonitorError(f"cannot serve the dashboard on {host}:{port}: {reason}") from None
    names.port = bound = runner.addresses[0][1] if runner.addresses else port
    shown = f"[{host}]" if ":" in host else host
    loop = asyncio.get_running_loop()
    previous = loop.get_exception_handler()
    loop.set_exception_handler(gate.loop_errors(previous, backlog))
    poll = asyncio.ensure_future(monitor.poll_forever())
    try:
        yield monitor, f"http://{shown}:{bound}/"
    finally:
        poll.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await poll
        await runner.cleanup()
        loop.set_exception_handler(previous)
        device.close()


def run(device: LiveDevice, host: str, port: int, *, allow_write: bool, title: str,
        say: Callable[[str], None], opened: Callable[[str], None] | None = None,
        duration: float | None = None) -> None:
    """Serve until Ctrl-C, SIGTERM or `duration` seconds; `opened(url)` once it listens
    (to open a browser). MonitorError when it cannot listen."""
    from mplang.family.stopsignals import on_stop_signals

    async def main() -> None:
        stop = asyncio.Event()
        with on_stop_signals(stop.set):
            await serve_until(stop)

    async def serve_until(stop: asyncio.Event) -> None:
        async with serving(device, host, port, allow_write=allow_write, title=title) \
                as (_monitor, url):
            say(f"dashboard on {url}" + (" (writes allowed)" if allow_write else
                                         " (read-only)"))
            if opened is not None:
                opened(url)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), duration)

    asyncio.run(main())


def is_loopback(host: str) -> bool:
    """Whether the dashboard bound to `host` is out of other machines' reach."""
    return host.strip("[]") in LOOPBACK or host.startswith("127.")
