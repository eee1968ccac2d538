"""The user's state and cache directories, where mpc keeps what belongs to no project (the
default flash record; parse tables and front-end results), as each platform has them
(platformdirs): `~/.local/state` and `~/.cache` on Linux, `%LOCALAPPDATA%` on Windows,
`~/Library/Application Support` and `~/Library/Caches` on macOS.

`XDG_STATE_HOME` and `XDG_CACHE_HOME`, set to an absolute path, are honoured on every
platform, so a user (or a test) moves them the same way everywhere.

On Linux and the other XDG systems the two directories are worked out here, as platformdirs
does (tests compare them with its answer): importing platformdirs costs a short `mpc` run
more than the rest of finding its cache, and every run looks for that. Windows and macOS ask
platformdirs.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

XDG_DEFAULTS = {"XDG_STATE_HOME": "~/.local/state", "XDG_CACHE_HOME": "~/.cache"}
"""Each variable's directory when it is not set (the XDG Base Directory specification)."""


def _home(variable: str) -> Path | None:
    """`variable` when it holds an absolute path, else the platform's directory; None when
    neither is absolute (no home directory to build it from)."""
    value = os.environ.get(variable)
    if value and os.path.isabs(value):
        return Path(value)
    try:
        found = _platform_dir(variable)
    except (RuntimeError, KeyError, OSError):  # no HOME and no password entry
        return None
    return Path(found) if os.path.isabs(found) else None


def _platform_dir(variable: str) -> str:
    """The platform's directory for `variable` (platformdirs' `user_state_dir` or
    `user_cache_dir`); RuntimeError or KeyError when there is no home to build it from."""
    if sys.platform == "win32" or sys.platform == "darwin":  # spelt so for mypy's platforms
        import platformdirs

        found: str = (platformdirs.user_state_dir() if variable == "XDG_STATE_HOME"
                      else platformdirs.user_cache_dir())
        return found
    return _expand_home(XDG_DEFAULTS[variable])


def _expand_home(path: str) -> str:
    """`~/...` under the user's home, as platformdirs expands it on POSIX: a relative HOME
    counts as unset (the password entry's home is taken); a home that is still not absolute
    is a RuntimeError."""
    home = os.environ.get("HOME")
    if sys.platform != "win32" and home is not None and not os.path.isabs(home):
        import pwd

        expanded = pwd.getpwuid(os.getuid()).pw_dir.rstrip("/") + path[1:] or "/"
    else:
        expanded = os.path.expanduser(path)
    if not os.path.isabs(expanded):
        raise RuntimeError(f"no home directory for {path!r}")
    return expanded


def state_home() -> Path | None:
    """The user's state directory (mpc's own is its `mpc` folder)."""
    return _home("XDG_STATE_HOME")


def cache_home() -> Path | None:
    """The user's cache directory (mpc's own is its `mplang` folder)."""
    return _home("XDG_CACHE_HOME")
