"""A loopback TCP server for the fault proxies of the flash tests: it listens on a free port
of 127.0.0.1, keeps the tasks it starts, and cancels them all when closed, so no test leaves
a task behind on its event loop."""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine
from typing import Any


class LoopbackServer:
    """Subclasses answer each connection in `_serve` and start side tasks with `_spawn`."""

    def __init__(self) -> None:
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()

    async def start(self) -> int:
        """Listen; the port."""
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        return int(self._server.sockets[0].getsockname()[1])

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)

    def _spawn(self, coroutine: Coroutine[Any, Any, None]) -> asyncio.Task[None]:
        task = asyncio.ensure_future(coroutine)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        raise NotImplementedError  # every proxy answers its connections itself
