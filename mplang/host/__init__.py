"""A Python host API: a controller spoken to in the source's names, checked against the
build it must hold (docs/host.md).

    import mplang.host

    with mplang.host.connect(tcp="192.168.0.16", sources=["job.mp"]) as ctl:
        ctl.vars["speed"] = 2000
        ctl.call("tour", timeout=60)       # ExecutionError at its source line if it fails
        print(ctl.vars["parts"], ctl.axes["X"].position)

`connect` raises `BuildMismatch` before anything is written when the device holds another
build (or none); `check=False` skips that. `connect_async` is the same with coroutines
(`AsyncController`). The sync `Controller` runs the async one on an event loop of its own,
in a thread, so it also works where a loop is already running.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Coroutine, Iterator, MutableMapping
from pathlib import Path
from typing import Any, TypeVar

from mplang.family.hostview import (
    BadValue,
    BuildMismatch,
    ExecutionError,
    HostError,
    HostLinkError,
    HostValue,
    HostView,
    ProgramRunning,
    UnknownName,
    WaitTimeout,
)
from mplang.host.session import AsyncController, Axis, BuildFailed, CallResult, NoHost, Plan
from mplang.ir.unit import Options

__all__ = ["AsyncController", "Axis", "BadValue", "BuildFailed", "BuildMismatch", "CallResult",
           "Controller", "ExecutionError", "HostError", "HostLinkError", "HostValue",
           "HostView", "NoHost", "ProgramRunning", "UnknownName", "WaitTimeout", "connect",
           "connect_async", "plan"]

T = TypeVar("T")
PathLike = str | Path


def plan(tcp: str | None = None, serial: str | None = None, *,
         sources: list[PathLike] | None = None, project: PathLike | None = None,
         image: PathLike | None = None, unit: int = 1, baud: int = 115200,
         timeout: float = 1.0, retries: int = 3, target: str | None = None,
         identity: str | bool | None = None) -> Plan:
    """What `connect` opens, checked: one device (`tcp` "HOST[:PORT]" or `serial`), one
    build (`sources`, a `project` mpc.toml, or an `image` / export JSON). ValueError says
    what is wrong."""
    from mplang.family.registry import DEFAULT_TARGET, family_of_target
    from mplang.tools import project as project_module

    if bool(tcp) == bool(serial):
        raise ValueError("give one device: tcp=\"HOST[:PORT]\" or serial=\"PORT\"")
    if sum(x is not None for x in (sources, project, image)) != 1:
        raise ValueError("give the build one way: sources=[...], project=... or image=...")
    if tcp is not None:
        host, port = project_module.parse_address(tcp)
        device = project_module.Target(f"{host}:{port}", host=host, port=port, unit=unit)
    else:
        device = project_module.Target(str(serial), serial=serial, unit=unit, baud=baud)
    options = Options()
    paths: tuple[Path, ...] = ()
    fixed = False
    if project is not None:
        try:
            loaded = project_module.load_project(Path(project))
        except project_module.ProjectError as exc:
            raise ValueError(str(exc)) from None
        paths = loaded.sources
        if not paths:
            raise ValueError(f"{project}: [project] lists no sources")
        options = Options(word_order=loaded.word_order, target=loaded.target or DEFAULT_TARGET,
                          temps=loaded.temp_vars or options.temps, pins=loaded.pins,
                          var_pool=loaded.var_pool or options.var_pool,
                          allow_outside_includes=bool(loaded.allow_outside_includes))
        fixed = loaded.word_order is not None
        if identity is None:
            identity = loaded.flash.identity
    elif sources is not None:
        paths = tuple(Path(p) for p in sources)
        if not paths:
            raise ValueError("sources=[] names no file")
    options = options.replace(target=target or options.target)
    family = family_of_target(options.target)
    if family is None:
        raise ValueError(f"unknown target {options.target!r}")
    return Plan(family, device, paths, None if image is None else Path(image), options,
                fixed, identity, timeout, retries)


def connect_async(tcp: str | None = None, serial: str | None = None, *,
                  sources: list[PathLike] | None = None, project: PathLike | None = None,
                  image: PathLike | None = None, check: bool = True, unit: int = 1,
                  **more: Any) -> AsyncController:
    """An `AsyncController` to use as `async with connect_async(...) as ctl:`."""
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    return AsyncController(plan(tcp, serial, sources=sources, project=project, image=image,
                                unit=unit, **more), check=check)


def connect(tcp: str | None = None, serial: str | None = None, *,
            sources: list[PathLike] | None = None, project: PathLike | None = None,
            image: PathLike | None = None, check: bool = True, unit: int = 1,
            **more: Any) -> Controller:
    """A `Controller` to use as `with connect(...) as ctl:`; the connection opens (and the
    device's build is checked) on entering."""
    return Controller(connect_async(tcp, serial, sources=sources, project=project,
                                    image=image, check=check, unit=unit, **more))


class _Loop:
    """An event loop in a daemon thread: the sync API's coroutines run there."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True,
                                       name="mplang.host")
        self.thread.start()

    def run(self, coro: Coroutine[Any, Any, T]) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result()

    def stop(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join()
        self.loop.close()


class Variables(MutableMapping[str, HostValue]):
    """`Controller.vars`: the declared variables by name, read and written on the device."""

    def __init__(self, ctl: Controller) -> None:
        self._ctl = ctl

    def __getitem__(self, name: str) -> HostValue:
        return self._ctl._run(self._ctl.async_controller.read_var(name))

    def __setitem__(self, name: str, value: HostValue) -> None:
        self._ctl._run(self._ctl.async_controller.write_var(name, value))

    def __delitem__(self, name: str) -> None:
        raise TypeError("a device variable cannot be deleted")

    def __iter__(self) -> Iterator[str]:
        return iter([v.name for v in self._ctl.view.variables])

    def __len__(self) -> int:
        return len(self._ctl.view.variables)


class Axes:
    """`Controller.axes["X"]`: one axis read now (`Axis`: position, state)."""

    def __init__(self, ctl: Controller) -> None:
        self._ctl = ctl

    def __getitem__(self, name: str) -> Axis:
        axes = self._ctl._run(self._ctl.async_controller.axes())
        try:
            return axes[name.upper()]
        except KeyError:
            raise UnknownName(f"no axis {name!r} (axes: {', '.join(axes)})") from None


class Controller:
    """The sync face of an `AsyncController`: `with connect(...) as ctl:`."""

    def __init__(self, async_controller: AsyncController) -> None:
        self.async_controller = async_controller
        self._loop: _Loop | None = None
        self.vars = Variables(self)
        self.axes = Axes(self)

    def __enter__(self) -> Controller:
        self.open()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def open(self) -> None:
        self._loop = _Loop()
        try:
            self._loop.run(self.async_controller.open())
        except BaseException:
            self._loop.stop()
            self._loop = None
            raise

    def close(self) -> None:
        if self._loop is not None:
            self._loop.run(self.async_controller.close())
            self._loop.stop()
            self._loop = None

    def _run(self, coro: Coroutine[Any, Any, T]) -> T:
        if self._loop is None:
            coro.close()
            raise HostError("the controller is not open (use `with connect(...) as ctl:`)")
        return self._loop.run(coro)

    @property
    def view(self) -> HostView:
        return self.async_controller.view

    @property
    def build_id(self) -> str:
        return self.async_controller.build_id

    @property
    def running(self) -> bool:
        return self._run(self.async_controller.running())

    @property
    def errors(self) -> list[ExecutionError]:
        """The execution error the device records (its last since power on), if any."""
        return self._run(self.async_controller.errors())

    def call(self, name: str, wait: bool = True, timeout: float | None = None) -> CallResult:
        return self._run(self.async_controller.call(name, wait, timeout))

    def wait(self, timeout: float | None = None) -> None:
        self._run(self.async_controller.wait(timeout))
