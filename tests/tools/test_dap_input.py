"""`mpc dap`'s input, in-process and property-based (bounded): the framing survives any
bytes and finds the next well-formed message after garbage; expressions (conditions,
evaluate) either read or say why, never anything else."""

from __future__ import annotations

import io
import json

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.tools.dap import expr
from mplang.tools.dap.framing import MAX_HEADER_LINE, Dropped, Reader, Writer

FAST = settings(max_examples=150, deadline=None, database=None, derandomize=True)


def frame(message: dict[str, object]) -> bytes:
    body = json.dumps(message).encode()
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


def read_all(data: bytes) -> list[bytes | Dropped]:
    """Every body and drop the reader gives for `data`; each call consumes input, so the
    number of calls is bounded by its length."""
    reader = Reader(io.BytesIO(data))
    found: list[bytes | Dropped] = []
    for _ in range(len(data) + 2):
        message = reader.next()
        if message is None:
            return found
        found.append(message)
    raise AssertionError("the reader did not reach the end of its input")


@FAST
@given(st.binary(max_size=2000))
def test_base_protocol_framing_survives_any_bytes(data: bytes) -> None:
    for message in read_all(data):
        assert isinstance(message, (bytes, Dropped))


@FAST
@given(st.lists(st.text(st.characters(blacklist_characters=":\r\n",
                                      blacklist_categories=("Cs",)), max_size=60),
                max_size=5))
def test_base_protocol_a_request_after_garbage_lines_is_read(garbage: list[str]) -> None:
    request = {"seq": 1, "type": "request", "command": "threads"}
    data = b"".join(line.encode() + b"\r\n" for line in garbage) + b"\r\n" + frame(request)
    bodies = [m for m in read_all(data) if isinstance(m, bytes)]
    assert bodies == [json.dumps(request).encode()]


def test_base_protocol_oversized_header_and_body_are_dropped_unread() -> None:
    huge_line = b"X" * (MAX_HEADER_LINE * 3) + b"\r\n"
    data = huge_line + b"Content-Length: 99999999999\r\n\r\n" + frame({"seq": 2})
    found = read_all(data)
    assert isinstance(found[0], Dropped) and "longer than" in found[0].reason
    assert found[1:] == [] or all(isinstance(m, Dropped) for m in found[1:])


def test_base_protocol_writer_frames_and_numbers_messages() -> None:
    out = io.BytesIO()
    writer = Writer(out)
    writer.send({"type": "event", "event": "initialized"})
    writer.send({"type": "event", "event": "terminated"})
    bodies = read_all(out.getvalue())
    assert [json.loads(b)["seq"] for b in bodies if isinstance(b, bytes)] == [1, 2]


@FAST
@given(st.text(max_size=200))
def test_evaluate_any_text_reads_or_says_why(text: str) -> None:
    try:
        tree = expr.parse(text)
    except expr.ExpressionError as exc:
        assert str(exc)
        return
    try:
        value = expr.evaluate(tree, lambda name: 7 if name != "missing" else None)
    except expr.ExpressionError as exc:
        assert str(exc)
        return
    assert isinstance(value, int)


@FAST
@given(st.integers(-2**31, 2**31 - 1), st.integers(-2**31, 2**31 - 1),
       st.sampled_from(["+", "-", "*", "/", "&", "|"]))
def test_evaluate_uses_the_device_arithmetic(left: int, right: int, op: str) -> None:
    """C division and the 32-bit wrap of VAR_CALCULATE (device profile [arithmetic])."""
    from mplang.ir.fold import apply_operator

    values = {"a": left, "b": right}
    tree = expr.parse(f"a {op} b")
    if op == "/" and right == 0:
        try:
            expr.evaluate(tree, values.get)
        except expr.ExpressionError as exc:
            assert "division by zero" in str(exc)
            return
        raise AssertionError("division by zero gave a value")
    assert expr.evaluate(tree, values.get) == apply_operator(op, left, right)


def test_evaluate_conditions_as_breakpoints_write_them() -> None:
    values = {"rows_done": 4, "VAR12": 0}
    for text, expected in (("rows_done > 3", 1), ("VAR12 == 0", 1),
                           ("rows_done > 3 && VAR12 != 0", 0), ("!VAR12", 1),
                           ("rows_done >= 4 || missing", 1), ("-rows_done", -4)):
        assert expr.evaluate(expr.parse(text), values.get) == expected, text
    assert expr.names(expr.parse("a + VAR3 * b")) == ["a", "VAR3", "b"]
