"""Rewriting source files as `mpc fmt` and `mpc lint --fix` do: a unified diff of what
would change (which `patch -p0` applies), and the atomic replacement of a file."""

from __future__ import annotations

import contextlib
import difflib
import os
import stat
import tempfile
from pathlib import Path


def _source_lines(text: str) -> list[str]:
    """Lines split where the compiler splits them (at "\n" only), each with its ending."""
    pieces = text.split("\n")
    return [piece + "\n" for piece in pieces[:-1]] + ([pieces[-1]] if pieces[-1] else [])


def unified_diff(before: str, after: str, display: str, label: str = "formatted") -> str:
    """A unified diff that `patch -p0` applies; a last line without a newline is marked."""
    lines = difflib.unified_diff(_source_lines(before), _source_lines(after),
                                 fromfile=f"{display}\t(original)",
                                 tofile=f"{display}\t({label})")
    out: list[str] = []
    for line in lines:
        out.append(line)
        if not line.endswith("\n"):
            out.append("\n\\ No newline at end of file\n")
    return "".join(out)


def write_atomically(path: Path, data: bytes) -> None:
    """Replace the file (the target of a symlink) in one rename, keeping its permissions."""
    target = path.resolve()
    mode = stat.S_IMODE(target.stat().st_mode)
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                         suffix=".mpc-fmt")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.chmod(temporary, mode)
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
