"""Builds of the package from this checkout, one at a time across the suite's workers.

`pip wheel --no-build-isolation` and `python -m build --no-isolation` write into the
checkout itself (`build/`, `mplang.egg-info/`), so two workers building at once can spoil
each other's build: one of them then fails. Three test files build the package; they take
this lock, a file made with O_EXCL in the folder the workers' temporary folders share.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

WAIT_S = 900.0
"""How long a build waits for another's (a build of the sdist and its wheel takes about
half a minute on a loaded machine)."""


@contextmanager
def checkout_build(scratch: Path) -> Iterator[None]:
    """Hold the checkout's build lock while the block runs. `scratch` is a worker's
    temporary folder (`tmp_path_factory.getbasetemp()`): under xdist its parent is the run's
    own, shared by every worker; without workers nothing else builds, and no lock is taken."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        yield
        return
    lock = scratch.parent / "checkout-build.lock"
    deadline = time.monotonic() + WAIT_S
    while True:
        try:
            handle = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            break
        except FileExistsError:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{lock} held for over {WAIT_S:.0f} s") from None
            time.sleep(0.2)
    try:
        yield
    finally:
        os.close(handle)
        lock.unlink()
