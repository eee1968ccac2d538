"""Ctrl-C and termination for the asyncio commands (`mpc sim`, `mpc flash`, `mpc monitor`),
the same on every platform.

A Unix event loop takes signal handlers (`loop.add_signal_handler`); Windows' loops do not
(they raise NotImplementedError). There the handler is a plain `signal.signal` one that hands
the callback to the loop with `call_soon_threadsafe`: Python runs it in the main thread as
soon as the loop's wait returns (Windows' proactor loop wakes itself on a signal; a selector
loop's wait is retried after the handler ran). Windows' Ctrl-Break (SIGBREAK) stops too.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import sys
from collections.abc import Callable, Iterator
from types import FrameType


def stop_signals() -> tuple[signal.Signals, ...]:
    """The signals that ask a command to stop: Ctrl-C, termination and (Windows) Ctrl-Break."""
    if sys.platform == "win32":
        return (signal.SIGINT, signal.SIGTERM, signal.SIGBREAK)
    return (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def on_stop_signals(callback: Callable[[], object]) -> Iterator[None]:
    """Within the block (run inside a running loop), call `callback` on that loop when
    Ctrl-C or a termination signal arrives; the previous handlers come back after it."""
    loop = asyncio.get_running_loop()
    signals = stop_signals()
    installed: list[signal.Signals] = []
    previous: dict[signal.Signals, signal.Handlers | Callable[..., object] | int | None] = {}
    try:
        for sig in signals:
            # remove_signal_handler puts back Python's default, not what was there (an
            # ignored SIGINT, a host program's own handler): keep it to put it back.
            previous[sig] = signal.getsignal(sig)
            loop.add_signal_handler(sig, callback)
            installed.append(sig)
    except NotImplementedError:  # Windows' loops: a plain handler that wakes the loop
        def handler(_number: int, _frame: FrameType | None) -> None:
            loop.call_soon_threadsafe(callback)

        for sig in signals:
            with contextlib.suppress(ValueError, OSError):  # not the main thread: none
                previous[sig] = signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig in installed:
            loop.remove_signal_handler(sig)
        for sig, old in previous.items():
            if old is not None:  # None: a handler not set from Python, nothing to restore
                with contextlib.suppress(ValueError, OSError):
                    signal.signal(sig, old)
