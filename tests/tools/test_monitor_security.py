"""`mpc monitor` is safe by construction (docs/monitor.md, "Security"): the real command as
a subprocess beside a real `mpc sim`, driven over raw loopback sockets and aiohttp with
forged Host and Origin headers, writes with and without the session's token, and a flood of
half-open connections under a lowered open-file limit.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import selectors
import socket
from collections.abc import Iterator
from pathlib import Path

import aiohttp
import pytest
from monitorproc import (
    get,
    limit_open_files,
    post,
    session_token,
    start_monitor,
    state_until,
    stop,
)
from simproc import start_sim


def raw(port: int, method: str, path: str, host: str | None,
        headers: dict[str, str] | None = None, body: bytes = b"") -> tuple[int, str, str]:
    """One request on its own connection, exactly as written (no client fixes the Host);
    the status, the head and the body of the answer."""
    lines = [f"{method} {path} HTTP/1.1"] + ([f"Host: {host}"] if host is not None else [])
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    lines += ["Connection: close", f"Content-Length: {len(body)}", "", ""]
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
        sock.sendall("\r\n".join(lines).encode() + body)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, rest = data.decode(errors="replace").partition("\r\n\r\n")
    return int(head.split()[1]), head, rest


def port_of(url: str) -> int:
    return int(url.rstrip("/").rsplit(":", 1)[1])


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """`mpc monitor --allow-write` of a running `mpc sim`: the dashboard's URL."""
    sim, port = start_sim("--duration", "300")
    try:
        monitor, url = start_monitor(tmp_path_factory.mktemp("w"), "--tcp",
                                     f"127.0.0.1:{port}", "--allow-write")
        try:
            state_until(url, lambda s: s["connected"])
            yield url
        finally:
            stop(monitor)
    finally:
        stop(sim)


ROUTES = [("GET", "/"), ("GET", "/favicon.ico"), ("GET", "/assets/monitor.js"),
          ("GET", "/api/state"), ("GET", "/api/session"), ("GET", "/ws"),
          ("POST", "/api/emergency-stop"), ("POST", "/api/call")]


def test_dns_rebinding_host_is_refused_on_every_route(dashboard: str) -> None:
    """Host is an exact list: a name that merely starts like loopback (the DNS-rebinding
    page of issue 23, `127.attacker.example:PORT`) is refused (421) on reads, the
    WebSocket and writes alike, with a valid token and a matching Origin; nothing moves."""
    port = port_of(dashboard)
    token = session_token(dashboard)
    foreign = [f"127.attacker.example:{port}", "127.attacker.example",
               f"127.0.0.1.attacker.example:{port}", f"localhost.attacker.example:{port}",
               f"127.0.0.2:{port}", "evil.example", f"127.0.0.1:{port + 1}",
               f"localhost:{port}0", f"[::2]:{port}", f"127.0.0.1:{port}@evil.example",
               f"localhost.:{port}", ""]
    for host in [*foreign, None]:
        for method, path in ROUTES:
            headers = {"X-MPC-Token": token, "Content-Type": "application/json",
                       "Upgrade": "websocket", "Connection": "Upgrade",
                       "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
                       "Sec-WebSocket-Version": "13"}
            if host:
                headers["Origin"] = f"http://{host}"
            status, _head, body = raw(port, method, path, host, headers, b"{}")
            if host is None:  # HTTP/1.1 without Host: refused by the parser already
                assert status == 400 and "Missing 'Host' header" in body
                continue
            assert status == 421, (host, method, path, status, body)
            assert "refused: the dashboard does not answer to the host name" in body
    state = get(dashboard + "api/state")[1]
    assert state["emergency"] is False  # no refused write reached the device
    for host in (f"127.0.0.1:{port}", "127.0.0.1", f"localhost:{port}", "LocalHost",
                 f"[::1]:{port}", "[::1]"):
        assert raw(port, "GET", "/api/state", host)[0] == 200, host


def test_origin_is_checked_on_writes_and_on_the_websocket_handshake(dashboard: str) -> None:
    """A foreign Origin is refused (403) on a write (even with the token), on the token's
    endpoint and on the WebSocket handshake; this dashboard's own Origin, and none at all
    (a program, not a page), are answered."""
    port = port_of(dashboard)
    token = session_token(dashboard)
    foreign = ["http://evil.example", "null", f"http://localhost:{port + 1}",
               f"https://127.0.0.1:{port}", f"http://127.attacker.example:{port}",
               f"http://127.0.0.1:{port}.evil.example", "http://127.0.0.1",
               f"file://127.0.0.1:{port}"]
    for origin in foreign:
        status, answer = post(dashboard + "api/emergency-stop", {}, token=token,
                              headers={"Origin": origin})
        assert status == 403 and "refused: a request from a page of" in answer["error"]
        assert raw(port, "GET", "/api/session", f"127.0.0.1:{port}",
                   {"Origin": origin})[0] == 403
    assert get(dashboard + "api/state")[1]["emergency"] is False

    async def handshake(origin: str | None) -> int:
        """The WebSocket handshake from a page of `origin`: 101 and a first message, or
        the status it was refused with."""
        async with aiohttp.ClientSession() as session:
            try:
                async with session.ws_connect(dashboard.replace("http", "ws") + "ws",
                                              origin=origin) as ws:
                    message = await ws.receive_json()
                    assert "state" in message
                    return 101
            except aiohttp.WSServerHandshakeError as err:
                return err.status

    for origin in foreign:
        assert asyncio.run(handshake(origin)) == 403, origin
    assert asyncio.run(handshake(f"http://127.0.0.1:{port}")) == 101
    assert asyncio.run(handshake(f"http://localhost:{port}")) == 101
    assert asyncio.run(handshake(None)) == 101
    own = post(dashboard + "api/emergency-stop", {}, token=token,
               headers={"Origin": f"http://127.0.0.1:{port}"})
    assert own[0] == 200
    state_until(dashboard, lambda s: s["emergency"] is True)
    assert post(dashboard + "api/clear-emergency", {}, token=token)[0] == 200
    state_until(dashboard, lambda s: s["emergency"] is False)


def test_a_write_needs_this_sessions_token(dashboard: str, tmp_path: Path) -> None:
    """Without the token (or with another one) a write is 403 and the device is not
    touched; the page carries the token, GET /api/session gives it to a script, and each
    dashboard process has its own. The page cannot be framed by another."""
    port = port_of(dashboard)
    token = session_token(dashboard)
    assert len(token) >= 40
    status, page = get(dashboard)
    assert status == 200
    found = re.search(r'<meta name="mpc-token" content="([^"]+)">', page)
    assert found is not None and found.group(1) == token
    for sent in (None, "", token[:-1], token + "x", token.upper()):
        status, answer = post(dashboard + "api/emergency-stop", {}, token=sent)
        assert status == 403 and "X-MPC-Token" in answer["error"], sent
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:  # not UTF-8
        sock.sendall(f"POST /api/stop HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: "
                     "close\r\nContent-Length: 0\r\nX-MPC-Token: ".encode() + b"\xff\xfe\r\n\r\n")
        assert sock.recv(4096).startswith(b"HTTP/1.1 403 ")
    assert get(dashboard + "api/state")[1]["emergency"] is False
    _status, head, _body = raw(port, "GET", "/", f"127.0.0.1:{port}")
    assert "X-Frame-Options: DENY" in head and "frame-ancestors 'none'" in head
    assert "Cache-Control: no-store" in head and "X-Content-Type-Options: nosniff" in head
    other, other_url = start_monitor(tmp_path, "--tcp", "127.0.0.1:1", "--allow-write")
    try:
        assert session_token(other_url) != token
        assert post(other_url + "api/stop", {}, token=token)[0] == 403
    finally:
        stop(other)


def half_open(port: int, count: int) -> list[socket.socket]:
    """`count` connections, opened all at once, that send the start of a request's headers
    and never the end (one the dashboard does not accept within 10 s, or refuses, is
    dropped from the list)."""
    opening = []
    for _ in range(count):
        sock = socket.socket()
        sock.setblocking(False)
        sock.connect_ex(("127.0.0.1", port))
        opening.append(sock)
    held = []
    with selectors.DefaultSelector() as selector:
        for sock in opening:
            selector.register(sock, selectors.EVENT_WRITE)
        while selector.get_map() and (ready := selector.select(timeout=10)):
            for key, _events in ready:
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                selector.unregister(sock)
                if sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) == 0:
                    sock.setblocking(True)
                    sock.settimeout(30)
                    with contextlib.suppress(OSError):  # closed by the dashboard already
                        sock.sendall(f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                                     .encode())
                        held.append(sock)
                        continue
                sock.close()
    for sock in opening:
        if sock not in held:
            sock.close()
    return held


def get_amid_flood(url: str) -> int:
    """The status of a GET sent while the flood's connections may still be entering the
    dashboard's accept queue: a request accepted in one burst with them, closed with them
    before its request was read, is sent again once (docs/monitor.md, "Security": the
    dashboard cannot tell it from them until its request is whole). A second reset fails."""
    try:
        return get(url)[0]
    except ConnectionResetError:
        return get(url)[0]


def closed_by_server(sock: socket.socket) -> bool:
    """Whether the server closed `sock` (reads its end, waiting up to the socket's
    timeout)."""
    try:
        return sock.recv(1024) == b""
    except ConnectionResetError:
        return True


def test_half_open_flood_keeps_the_page_answering(tmp_path: Path) -> None:
    """Issue 23's ~1,100 half-open connections at a 1,024-file limit, scaled down: at a
    128-file limit, 300 connections that never finish their headers. The dashboard keeps
    at most its cap open (64 there: a quarter of the files and two accept bursts of 16
    left free), closing the oldest unfinished ones, and answers the page through
    the flood; the limit then lowered under it (EMFILE on accept) is one warning line and
    the page still answers; a connection that never finishes its headers, or a write whose
    body never arrives, is closed in time (HEADER_TIMEOUT_S, BODY_TIMEOUT_S). No
    traceback."""
    errors = (tmp_path / "stderr.txt").open("w+")
    monitor, url = start_monitor(tmp_path, "--tcp", "127.0.0.1:1", "--allow-write",
                                 stderr=errors, open_files=128)
    port = port_of(url)
    held: list[socket.socket] = []
    try:
        held += half_open(port, 300)
        for _ in range(3):
            assert get(url + "api/state")[0] == 200
            assert get(url)[0] == 200
        limit_open_files(48, monitor.pid)  # fewer files than the dashboard's cap of 64
        held += half_open(port, 100)
        for _ in range(3):
            assert get_amid_flood(url + "api/state") == 200
        token = session_token(url)
        slow_headers = half_open(port, 1)[0]
        slow_body = socket.create_connection(("127.0.0.1", port), timeout=30)
        slow_body.sendall(f"POST /api/var HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-MPC-Token: "
                          f"{token}\r\nContent-Type: application/json\r\nContent-Length: "
                          f"100\r\n\r\n{{\"name\":".encode())
        assert closed_by_server(slow_headers)
        answer = b""
        while chunk := slow_body.recv(4096):
            answer += chunk
        assert answer.startswith(b"HTTP/1.1 408") and b"did not arrive within" in answer
        slow_headers.close()
        slow_body.close()
        assert get(url + "api/state")[0] == 200
    finally:
        for sock in held:
            sock.close()
        stop(monitor)
    errors.seek(0)
    log = errors.read()
    assert "Traceback" not in log and "Too many open files" not in log, log
    assert log.count("connections to the dashboard, past its limit of 64") == 1, log
    assert log.count("out of file descriptors (open-file limit 48)") == 1, log
    assert all(line.startswith("mpc monitor: warning: ") for line in log.splitlines()), log


def test_a_wildcard_bind_answers_ip_literals_not_names(tmp_path: Path) -> None:
    """Bound to 0.0.0.0 the dashboard is reached through any of the machine's addresses:
    an IP literal in Host is answered (it cannot be rebound), a name is still refused."""
    proc, url = start_monitor(tmp_path, "--tcp", "127.0.0.1:1", "--bind", "0.0.0.0")
    port = port_of(url)
    try:
        assert raw(port, "GET", "/api/state", f"127.0.0.1:{port}")[0] == 200
        assert raw(port, "GET", "/api/state", f"10.1.2.3:{port}")[0] == 200
        assert raw(port, "GET", "/api/state", f"machine.example:{port}")[0] == 421
        assert raw(port, "GET", "/api/state", f"127.attacker.example:{port}")[0] == 421
    finally:
        stop(proc)
