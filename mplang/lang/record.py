"""Light bases for value classes whose methods are written out instead of made by
`@dataclass`.

`@dataclass` generates each class's `__init__`, `__eq__`, `__repr__` (and for a frozen one
`__hash__`, `__setattr__`, `__delattr__`) as source text and compiles it when the module is
imported: about half a millisecond a class, paid by every `mpc` process for every class it
imports. A subclass here writes its `__init__` by hand and names its fields in `_fields`;
the rest is shared, and behaves as the dataclass did.
"""

from __future__ import annotations

from dataclasses import FrozenInstanceError
from typing import Any, ClassVar, NoReturn, Self


class FrozenRecordError(FrozenInstanceError):
    """A field of a frozen record was assigned or deleted: what a frozen dataclass raises
    (`dataclasses` is loaded anyway by the classes that stay dataclasses)."""


class Record:
    """As `@dataclass` behaves: equal when of the same class with equal fields (compared as
    tuples, in `_fields` order), unhashable (mutable), shown as `Name(a=.., b=..)`."""

    _fields: ClassVar[tuple[str, ...]] = ()
    __hash__ = None  # type: ignore[assignment]  # compared by value and mutable

    def _values(self) -> tuple[Any, ...]:
        return tuple(getattr(self, name) for name in self._fields)

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        names = self._fields
        return tuple(getattr(self, n) for n in names) == tuple(getattr(other, n) for n in names)

    def __repr__(self) -> str:
        shown = ", ".join(f"{name}={getattr(self, name)!r}" for name in self._fields)
        return f"{type(self).__qualname__}({shown})"

    def replace(self, **changes: Any) -> Self:
        """A copy with `changes` (`dataclasses.replace`): built through `__init__`, so a
        default factory is not re-run for a field that is kept."""
        values = {name: getattr(self, name) for name in self._fields}
        unknown = set(changes) - set(values)
        if unknown:
            raise TypeError(f"{type(self).__name__} has no field {sorted(unknown)[0]!r}")
        values.update(changes)
        return type(self)(**values)


class FrozenRecord(Record):
    """As `@dataclass(frozen=True)` behaves: a `Record` that is hashable by its fields and
    refuses assignment. Its `__init__` fills `self.__dict__` directly; `functools.
    cached_property` does too, so it still works on one."""

    def __hash__(self) -> int:  # type: ignore[override]  # Record's is None
        return hash(self._values())

    def __setattr__(self, name: str, value: object) -> NoReturn:
        raise FrozenRecordError(f"cannot assign to field {name!r} of {type(self).__name__}")

    def __delattr__(self, name: str) -> NoReturn:
        raise FrozenRecordError(f"cannot delete field {name!r} of {type(self).__name__}")
