"""SHA-256 for cache keys, file names and build ids, without loading OpenSSL.

`hashlib` loads `_hashlib`, OpenSSL's bindings, when it is imported: 10-20 ms of a short
`mpc` run, for a digest CPython also computes in its own small extension module (`_sha256`
in Python 3.11, `_sha2` from 3.12). Both give SHA-256's digests, the same bytes as
`hashlib.sha256`. A Python built without them (some distributions drop the builtin hashes
when OpenSSL provides them) falls back to `hashlib`, so a digest never changes, only the
time its first use takes.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Protocol

BUILTIN_MODULES = ("_sha2", "_sha256")
"""CPython's own SHA-256 modules, newest first: `_sha2` (3.12+), `_sha256` (3.11)."""


class Hasher(Protocol):
    """What a SHA-256 object offers here: fed in parts, read as hex or bytes."""

    def update(self, data: bytes, /) -> None: ...

    def hexdigest(self) -> str: ...

    def digest(self) -> bytes: ...


def find_sha256(modules: tuple[str, ...] = BUILTIN_MODULES) -> Callable[[bytes], Hasher]:
    """The `sha256` constructor of the first of `modules` that imports, else hashlib's."""
    for name in modules:
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        constructor = getattr(module, "sha256", None)
        if constructor is not None:
            return constructor  # type: ignore[no-any-return]
    import hashlib  # no builtin SHA-256: OpenSSL's, with the same digests

    return hashlib.sha256


_constructor = find_sha256()


def sha256(data: bytes = b"") -> Hasher:
    """A SHA-256 object fed `data`, as `hashlib.sha256(data)` makes one."""
    return _constructor(data)
