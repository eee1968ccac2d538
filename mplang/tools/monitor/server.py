"""The dashboard's web server: polls a `LiveDevice` (20 times a second by default) and serves
the page, `GET /api/state`, the WebSocket `/ws` (one message per poll: the state and the
path points added since the last message) and, with `allow_write`, the write endpoints
(`POST /api/call`, `/api/var`, `/api/stop`, `/api/emergency-stop`, `/api/clear-emergency`);
without it they answer 403. A device that cannot be read is a state like any other
(`connected` false, `error` saying why), never an exception out of the poll.

Writes must be JSON (`Content-Type: application/json`), which a page of another origin can
only send after a CORS preflight this server never grants, and an `Origin` header, when
sent, must be this server's own. Served on loopback, it answers only requests that name a
loopback host.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import json
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

from mplang.family.face import CommandError, DeviceUnreachable, LiveDevice
from mplang.lang.limits import load_json

PERIOD_S = 0.05  # 20 polls a second while the device answers
RETRY_S = 0.5  # between attempts while it does not
PATH_LIMIT = 100_000  # path points kept; the oldest half goes when it is reached
ASSETS = {"monitor.js": "text/javascript", "monitor.css": "text/css"}
ACTIONS = {"call": "call", "var": "set_var", "stop": "stop",
           "emergency-stop": "emergency_stop", "clear-emergency": "clear_emergency"}
LOOPBACK = ("127.0.0.1", "localhost", "::1")


class MonitorError(Exception):
    """The dashboard cannot be served (its port is taken, the address is not this
    machine's)."""


def _asset(name: str) -> bytes:
    return (resources.files("mplang.tools.monitor") / "assets" / name).read_bytes()


class Monitor:
    """The polled state of one device, its tool path, and the clients watching it."""

    def __init__(self, device: LiveDevice, *, allow_write: bool, period: float = PERIOD_S,
                 title: str = "", local_names_only: bool = True) -> None:
        self.device = device
        self.allow_write = allow_write
        self.period = period
        self.title = title
        self.local_names_only = local_names_only  # served on loopback: see `_local`
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
        return web.Response(body=_asset("index.html"), content_type="text/html",
                            charset="utf-8")

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
        if not self.allow_write:
            return web.json_response({"error": "read-only: writing needs mpc monitor "
                                      "--allow-write"}, status=403)
        origin = request.headers.get("Origin")
        if origin is not None and origin.split("://", 1)[-1] != request.host:
            return web.json_response({"error": f"refused: a write from {origin}"},
                                     status=403)
        if request.content_type != "application/json":
            return web.json_response({"error": "send the request as application/json"},
                                     status=415)
        try:  # nesting bounded before decoding: a hostile body is a 400, never a 500
            args = load_json(await request.text()) if request.can_read_body else {}
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
    async def _local(self, request: web.Request,
                     handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
                     ) -> web.StreamResponse:
        """On loopback, answer only requests that name this machine (Host: 127.0.0.1,
        localhost, [::1]): a page of another site whose name was made to point here (DNS
        rebinding) names its own."""
        if self.local_names_only and not is_loopback(request.url.host or ""):
            return web.json_response({"error": f"refused: the dashboard is served to "
                                      f"this machine, not to {request.host}"}, status=403)
        return await handler(request)

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._local])
        app.router.add_get("/", self.page)
        app.router.add_get("/assets/{name}", self.asset)
        app.router.add_get("/api/state", self.api_state)
        app.router.add_get("/ws", self.websocket)
        app.router.add_post("/api/{action:" + "|".join(ACTIONS) + "}", self.write)
        return app


@contextlib.asynccontextmanager
async def serving(device: LiveDevice, host: str, port: int, *, allow_write: bool,
                  title: str = "", period: float = PERIOD_S) -> AsyncIterator[
                      tuple[Monitor, str]]:
    """Serve the dashboard of `device` on host:port (0: any free port) while the block
    runs; yields the monitor and its URL. MonitorError when it cannot listen."""
    monitor = Monitor(device, allow_write=allow_write, period=period, title=title,
                      local_names_only=is_loopback(host))
    runner = web.AppRunner(monitor.app(), access_log=None, handle_signals=False)
    await runner.setup()
    try:
        await web.TCPSite(runner, host, port, shutdown_timeout=0.5).start()
    except OSError as exc:
        await runner.cleanup()
        device.close()
        reason = "the port is in use (another mpc monitor? choose one with --port)" \
            if exc.errno == errno.EADDRINUSE else exc.strerror or str(exc)
        raise MonitorError(f"cannot serve the dashboard on {host}:{port}: {reason}") from None
    bound = runner.addresses[0][1] if runner.addresses else port
    shown = f"[{host}]" if ":" in host else host
    poll = asyncio.ensure_future(monitor.poll_forever())
    try:
        yield monitor, f"http://{shown}:{bound}/"
    finally:
        poll.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await poll
        await runner.cleanup()
        device.close()


def run(device: LiveDevice, host: str, port: int, *, allow_write: bool, title: str,
        say: Callable[[str], None], opened: Callable[[str], None] | None = None,
        duration: float | None = None) -> None:
    """Serve until Ctrl-C, SIGTERM or `duration` seconds; `opened(url)` once it listens
    (to open a browser). MonitorError when it cannot listen."""
    import signal

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
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
    return host in LOOPBACK or host.startswith("127.")
