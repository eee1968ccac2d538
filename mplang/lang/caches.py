"""Where mpc keeps what it can rebuild (lark's parse tables, the catalogue, front-end
results), and how: pickles written under a fresh name and renamed into place, so a
concurrent run reads a whole file or none, and read back only when their key matches: the
keys head the file, compared before anything is unpickled.

The user cache directory is `mplang` in the user's cache directory (`mplang.lang.userdirs`:
`$XDG_CACHE_HOME`, else `~/.cache` on Linux, `%LOCALAPPDATA%` on Windows); `MPLANG_CACHE`
names another directory, or (empty, `0`, `off`) turns every cache off. A cache that cannot
be read or written, is damaged or was written for other inputs is ignored: rebuilding is
only slower, never different.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import sys
from pathlib import Path

from mplang import __version__
from mplang.lang.digest import sha256
from mplang.lang.userdirs import cache_home

OFF_WORDS = ("", "0", "off", "no", "false")
STAMP = f"mplang {__version__} python {sys.version_info[0]}.{sys.version_info[1]}"
"""Part of every key: a cache of another mpc or Python is never read."""


_turned_off = False


def turn_off(off: bool = True) -> None:
    """`--no-cache`: no cache is read or written by this process from now on (or again)."""
    global _turned_off
    _turned_off = off


def user_cache_dir() -> Path | None:
    """The directory of mpc's caches, or None when caching is turned off."""
    if _turned_off:
        return None
    chosen = os.environ.get("MPLANG_CACHE")
    if chosen is not None:
        return None if chosen.strip().lower() in OFF_WORDS else Path(chosen)
    base = cache_home()
    return None if base is None else base / "mplang"


def digest(*parts: str | bytes) -> str:
    """A key from the inputs a cached result depends on (and STAMP)."""
    hasher = sha256(STAMP.encode())
    for part in parts:
        hasher.update(b"\0")
        hasher.update(part.encode("utf-8", "surrogatepass") if isinstance(part, str) else part)
    return hasher.hexdigest()


def load(path: Path, key: str) -> object | None:
    """What `store` kept at `path` under `key`, or None (absent, damaged, another key)."""
    found = load_keyed(path, (key,))
    return None if found is None else found[1]


def load_keyed(path: Path, keys: tuple[str, ...]) -> tuple[int, object] | None:
    """The first of `keys` the entry at `path` was stored under (its index) and its value,
    or None. The keys head the file, so an entry of other inputs is never unpickled."""
    try:
        with open(path, "rb") as stream:
            stored = stream.readline(_HEAD_LIMIT).rstrip(b"\n").decode("ascii").split(" ")
            index = next((i for i, key in enumerate(keys) if key in stored), None)
            if index is None:
                return None
            value = pickle.load(stream)
    except Exception:
        return None
    return index, value


_HEAD_LIMIT = 4096


def store(path: Path, key: str, value: object, *also: str) -> None:
    """Keep `value` at `path` under `key` (and the keys `also`), atomically; silently
    nothing when it cannot."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        import tempfile  # only a run that keeps something new needs it

        descriptor, scratch = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".tmp")
    except OSError:
        return
    try:
        with os.fdopen(descriptor, "wb") as stream:
            stream.write(" ".join((key, *also)).encode("ascii") + b"\n")
            pickle.dump(value, stream, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(scratch, path)
    except Exception:
        with contextlib.suppress(OSError):
            os.unlink(scratch)
