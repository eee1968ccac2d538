"""The dashboard's Host and Origin lists (mplang.tools.monitor.guard) over drawn names: a
name is answered only when it is exactly one of the list, never because it starts like one
(issue 23: `127.attacker.example` was taken for loopback). The served command is tested in
test_monitor_security.py; this covers the names no hand-written list would think of."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.tools.monitor.guard import Names, split_host

PORT = 8194
NAMES = ["127.0.0.1", "[::1]", "localhost"]
ALLOWED_HOSTS = {*NAMES, "::1", *(f"{n}:{PORT}" for n in NAMES)}
ALLOWED_ORIGINS = {f"http://{n}:{PORT}" for n in NAMES}
PIECES = st.sampled_from(["127.", "0.0.1", "127.0.0.1", "localhost", "LOCALHOST", "::1",
                          "[", "]", ":", str(PORT), "8195", ".", "attacker", ".example",
                          "http://", "https://", "@", " ", "%2e", "0", "1", "-", "_"])
DRAWN = st.lists(PIECES, max_size=8).map("".join) | st.text(max_size=30)


@settings(max_examples=400)
@given(DRAWN)
def test_a_host_is_answered_only_when_it_is_one_of_the_list(host: str) -> None:
    names = Names("127.0.0.1", PORT)
    assert names.host_ok(host) == (host.strip().lower() in ALLOWED_HOSTS), host


@settings(max_examples=400)
@given(DRAWN)
def test_an_origin_is_this_dashboards_only_when_it_is_one_of_the_list(origin: str) -> None:
    names = Names("127.0.0.1", PORT)
    assert names.origin_ok(origin) == (origin.strip().lower() in ALLOWED_ORIGINS), origin


def test_the_bind_address_joins_the_list_and_a_wildcard_takes_ip_literals_only() -> None:
    lan = Names("192.168.0.5", PORT)
    assert lan.host_ok(f"192.168.0.5:{PORT}") and lan.origin_ok(f"http://192.168.0.5:{PORT}")
    assert not lan.host_ok(f"192.168.0.6:{PORT}") and not lan.host_ok("pc.example")
    anywhere = Names("0.0.0.0", PORT)
    assert anywhere.host_ok(f"10.0.0.7:{PORT}") and anywhere.host_ok(f"[fe80::1]:{PORT}")
    assert not anywhere.host_ok(f"pc.example:{PORT}")
    assert not anywhere.host_ok(f"127.attacker.example:{PORT}")
    on_80 = Names("127.0.0.1", 80)
    assert on_80.origin_ok("http://localhost") and not Names("::1", PORT).origin_ok(
        "http://localhost")
    assert split_host("[::1]:99999") is None and split_host(":80") is None
    for odd in (f"localhost:0{PORT}", "localhost:\uff18\uff11\uff19\uff14", "localhost:\u00b2",
                f"localhost:+{PORT}", f"localhost: {PORT}", "localhost:"):
        assert not Names("127.0.0.1", PORT).host_ok(odd), odd
