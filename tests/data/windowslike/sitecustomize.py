"""A Windows-like standard library for mplang, on Linux (tests/test_windows_like.py puts
this folder on PYTHONPATH of the `mpc` subprocesses it runs).

What mplang would meet on Windows and can be reproduced here:
- an import of a POSIX-only module (pty, tty, termios, fcntl, resource, grp, pwd) made by
  mplang's own code fails with ModuleNotFoundError, as on Windows. Third-party packages
  keep theirs: on Windows they take their own Windows branch (pyserial's serialwin32), which
  this machine cannot run;
- asyncio's event loops have no signal handlers: `loop.add_signal_handler` raises
  NotImplementedError, as Windows' proactor and selector loops do, so Ctrl-C and termination
  must go through `signal.signal` / KeyboardInterrupt.
"""

from __future__ import annotations

import builtins
import sys
from typing import Any

POSIX_ONLY = frozenset({"pty", "tty", "termios", "fcntl", "resource", "grp", "pwd"})

_import = builtins.__import__


def _windows_like_import(name: str, globals: dict[str, Any] | None = None,
                         locals: dict[str, Any] | None = None,
                         fromlist: tuple[str, ...] | list[str] = (), level: int = 0) -> Any:
    importer = (globals or {}).get("__name__") or ""
    if level == 0 and name.split(".")[0] in POSIX_ONLY and \
            (importer == "mplang" or importer.startswith("mplang.")):
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    return _import(name, globals, locals, fromlist, level)


builtins.__import__ = _windows_like_import

if sys.platform != "win32":
    import asyncio.unix_events

    for _method in ("add_signal_handler", "remove_signal_handler"):
        # falls back to AbstractEventLoop's, which raises NotImplementedError
        delattr(asyncio.unix_events._UnixSelectorEventLoop, _method)
