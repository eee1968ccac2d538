"""The builtin SHA-256 gives hashlib's digests, and hashlib stands in where it is missing."""

from __future__ import annotations

import hashlib
import importlib.util
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.lang import digest

builtin_only = pytest.mark.skipif(
    not any(importlib.util.find_spec(name) for name in digest.BUILTIN_MODULES),
    reason="this Python was built without its own SHA-256 module")


@settings(max_examples=60)
@given(st.lists(st.binary(max_size=300), max_size=5))
def test_digests_equal_hashlib(parts: list[bytes]) -> None:
    ours, theirs = digest.sha256(), hashlib.sha256()
    for part in parts:
        ours.update(part)
        theirs.update(part)
    assert ours.hexdigest() == theirs.hexdigest()
    assert ours.digest() == theirs.digest()
    joined = b"".join(parts)
    assert digest.sha256(joined).hexdigest() == hashlib.sha256(joined).hexdigest()


@builtin_only
def test_a_builtin_module_is_used_where_python_has_one() -> None:
    """CPython 3.11 has `_sha256`, 3.12 and later `_sha2`: neither is OpenSSL's hashlib."""
    assert digest.find_sha256() is not hashlib.sha256
    assert digest.find_sha256().__module__ in digest.BUILTIN_MODULES


def test_without_a_builtin_module_hashlib_stands_in() -> None:
    found = digest.find_sha256(("_no_such_sha_module", "os"))  # `os` has no sha256
    assert found is hashlib.sha256
    assert found(b"mpc").hexdigest() == digest.sha256(b"mpc").hexdigest()


@builtin_only
def test_importing_it_loads_no_openssl() -> None:
    done = subprocess.run(
        [sys.executable, "-c", "import sys, mplang.lang.digest as d; d.sha256(b'x').hexdigest();"
         " print('_hashlib' in sys.modules, 'hashlib' in sys.modules)"],
        capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["False", "False"]
