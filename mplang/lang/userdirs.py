"""The user's state and cache directories, where mpc keeps what belongs to no project (the
default flash record; parse tables and front-end results), as each platform has them
(platformdirs): `~/.local/state` and `~/.cache` on Linux, `%LOCALAPPDATA%` on Windows,
`~/Library/Application Support` and `~/Library/Caches` on macOS.

`XDG_STATE_HOME` and `XDG_CACHE_HOME`, set to an absolute path, are honoured on every
platform, so a user (or a test) moves them the same way everywhere.

platformdirs is imported when a variable does not answer: on Unix its module imports
`tempfile` (for the runtime directory's fallback), and with it `shutil`, `bz2`, `lzma` and
`random`, a tenth of a `mpc lint` that hits its caches. Importing the platform's module
(`platformdirs.unix`) directly would not avoid that: the package, and the same module, are
imported either way.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path


def _home(variable: str, platform_dir: Callable[[], str]) -> Path | None:
    """`variable` when it holds an absolute path, else the platform's directory; None when
    neither is absolute (no home directory to build it from)."""
    value = os.environ.get(variable)
    if value and os.path.isabs(value):
        return Path(value)
    try:
        found = platform_dir()
    except (RuntimeError, KeyError, OSError):  # no HOME and no password entry
        return None
    return Path(found) if os.path.isabs(found) else None


def _platform_state_dir() -> str:
    import platformdirs  # only when XDG_STATE_HOME does not answer (the module's docstring)

    return platformdirs.user_state_dir()


def _platform_cache_dir() -> str:
    import platformdirs  # only when XDG_CACHE_HOME does not answer (the module's docstring)

    return platformdirs.user_cache_dir()


def state_home() -> Path | None:
    """The user's state directory (mpc's own is its `mpc` folder)."""
    return _home("XDG_STATE_HOME", _platform_state_dir)


def cache_home() -> Path | None:
    """The user's cache directory (mpc's own is its `mplang` folder)."""
    return _home("XDG_CACHE_HOME", _platform_cache_dir)
