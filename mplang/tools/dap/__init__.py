"""`mpc dap`: a Debug Adapter Protocol server over stdio for `.mp` programs on the virtual
controller (docs/debug.md).

`framing` reads and writes the protocol's messages, `launch` turns a launch request into a
build and a debuggee (the family face's `debug`), `session` answers the requests. The
debuggee itself, stepping and breakpoints in source terms, belongs to the family
(`mplang.family.debug`, `mplang.m8194h.debugger`).
"""

from __future__ import annotations

from typing import BinaryIO

from mplang.tools.dap.framing import Reader, Writer
from mplang.tools.dap.session import Session

__all__ = ["serve"]


def serve(reader: BinaryIO, writer: BinaryIO) -> None:
    """Answer requests from `reader` on `writer` until `disconnect` or the end of input."""
    session = Session(Writer(writer))
    messages = Reader(reader)
    try:
        while not session.done:
            message = messages.next()
            if message is None:
                break
            session.handle(message)
    finally:
        session.close()
