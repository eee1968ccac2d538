"""`mpc dap`: a Debug Adapter Protocol server over stdio for `.mp` programs on the virtual
controller (docs/debug.md).

`framing` reads (with the reader `mpc lsp` shares, `mplang.tools.framing`) and writes
the protocol's messages, `launch` turns a launch request into a
build and a debuggee (the family face's `debug`), `session` answers the requests. The
debuggee itself, stepping and breakpoints in source terms, belongs to the family
(`mplang.family.debug`, `mplang.m8194h.debugger`).
"""

from __future__ import annotations

from typing import BinaryIO

from mplang.tools.dap.framing import Writer, reader
from mplang.tools.dap.session import Session

__all__ = ["serve"]


def serve(stream: BinaryIO, writer: BinaryIO) -> None:
    """Answer requests from `stream` on `writer` until `disconnect` or the end of input."""
    session = Session(Writer(writer))
    messages = reader(stream)
    try:
        while not session.done:
            message = messages.next()
            if message is None:
                break
            session.handle(message)
    finally:
        session.close()
