"""The value classes written out on `mplang.lang.record` instead of made by `@dataclass` must
behave as the dataclasses did: fields named alike in annotations, `_fields`, `__match_args__`
and `__init__` (or equality, repr and `replace` would silently skip one); equality by value;
a frozen one hashable and refusing assignment, a mutable one unhashable; a default factory
fresh per instance; pickling (the catalogue and the front cache store these) and copying."""

from __future__ import annotations

import copy
import dataclasses
import importlib
import inspect
import pickle
from typing import Any

import pytest

from mplang.lang.record import FrozenRecord, FrozenRecordError, Record

CONVERTED = ("mplang.ir.macro", "mplang.ir.configure", "mplang.ir.scope", "mplang.ir.interrupts",
             "mplang.ir.lower", "mplang.lang.sources", "mplang.lang.rules",
             "mplang.family.hostview", "mplang.family.registry", "mplang.m8194h.image",
             "mplang.m8194h.link", "mplang.tools.project", "mplang.cli.common",
             "mplang.cli.families", "mplang.ir.catalogue", "mplang.family.face",
             "mplang.family.run_error", "mplang.lang.diagnostics", "mplang.ir.unit",
             "mplang.m8194h.chipvalues", "mplang.lang.structure", "mplang.ir.reuse",
             "mplang.m8194h.compiler")
"""Modules that no longer define a dataclass: importing them creates none."""

PARTLY: dict[str, set[str]] = {}
"""Modules whose named classes stay dataclasses (code elsewhere calls `dataclasses.replace`
on them)."""


def _records() -> list[type[Record]]:
    found = []
    for module_name in (*CONVERTED, *PARTLY):
        module = importlib.import_module(module_name)
        found += [cls for cls in vars(module).values() if inspect.isclass(cls)
                  and issubclass(cls, Record) and cls.__module__ == module_name]
    return sorted(found, key=lambda cls: f"{cls.__module__}.{cls.__qualname__}")


RECORDS = _records()


def _name(cls: type) -> str:
    return f"{cls.__module__.rsplit('.', 1)[-1]}.{cls.__qualname__}"


def _sample(cls: type[Record], required_only: bool = False) -> Record:
    """An instance whose every field holds a distinct hashable value (`(name, index)`), or
    with the required fields only."""
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]
    values = {p.name: (p.name, index) for index, p in enumerate(parameters)
              if not required_only or p.default is inspect.Parameter.empty}
    return cls(**values)


def test_the_converted_modules_define_no_dataclass() -> None:
    for module_name in (*CONVERTED, *PARTLY):
        module = importlib.import_module(module_name)
        made = {cls.__name__ for cls in vars(module).values() if inspect.isclass(cls)
                and dataclasses.is_dataclass(cls) and cls.__module__ == module_name}
        assert made == PARTLY.get(module_name, set()), module_name


def test_every_record_is_checked() -> None:
    assert len(RECORDS) >= 47


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_fields_annotations_and_init_agree(cls: type[Record]) -> None:
    annotated = tuple(cls.__annotations__)
    parameters = tuple(inspect.signature(cls.__init__).parameters)[1:]
    assert cls._fields == annotated == parameters
    assert cls.__match_args__ == cls._fields  # type: ignore[attr-defined]


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_equality_repr_and_replace(cls: type[Record]) -> None:
    made = _sample(cls)
    assert {name: getattr(made, name) for name in cls._fields} == {
        name: (name, index) for index, name in enumerate(cls._fields)}
    assert made == _sample(cls) and made is not _sample(cls)
    first = cls._fields[0]
    changed = made.replace(**{first: "other"})
    assert getattr(changed, first) == "other" and changed != made
    assert made.replace() == made and made.replace() is not made
    with pytest.raises(TypeError, match="no field 'nonesuch'"):
        made.replace(nonesuch=1)
    assert repr(made) == f"{cls.__qualname__}(" + ", ".join(
        f"{name}={(name, index)!r}" for index, name in enumerate(cls._fields)) + ")"
    assert made != object() and (made == object()) is False


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_frozen_ones_hash_and_refuse_assignment_mutable_ones_do_not_hash(
        cls: type[Record]) -> None:
    made = _sample(cls)
    first = cls._fields[0]
    if issubclass(cls, FrozenRecord):
        assert hash(made) == hash(_sample(cls))
        assert len({made, _sample(cls)}) == 1
        with pytest.raises(FrozenRecordError):
            setattr(made, first, 1)
        with pytest.raises(AttributeError):
            delattr(made, first)
    else:
        with pytest.raises(TypeError, match="unhashable"):
            hash(made)
        setattr(made, first, 1)
        assert getattr(made, first) == 1


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_default_factories_are_fresh_per_instance(cls: type[Record]) -> None:
    one, two = _sample(cls, required_only=True), _sample(cls, required_only=True)
    assert one == two
    for name in cls._fields:
        value: Any = getattr(one, name)
        if isinstance(value, (list, dict, set)):
            assert value == type(value)() and value is not getattr(two, name), name


@pytest.mark.parametrize("cls", RECORDS, ids=_name)
def test_pickle_and_copy_keep_the_value(cls: type[Record]) -> None:
    made = _sample(cls)
    for again in (pickle.loads(pickle.dumps(made, pickle.HIGHEST_PROTOCOL)), copy.copy(made),
                  copy.deepcopy(made)):
        assert again == made and type(again) is cls
        if isinstance(made, FrozenRecord):
            assert hash(again) == hash(made)


def test_pattern_matching_by_position() -> None:
    from mplang.ir.macro import ProgramRef, VarRef
    match VarRef(3), ProgramRef(slot=4):
        case (VarRef(index), ProgramRef(None, slot)):
            assert (index, slot) == (3, 4)
        case _:
            pytest.fail("no match")


def test_a_frozen_command_still_caches_its_short_name() -> None:
    from mplang.ir.catalogue import load
    command = load().macro("FIXED_MOVE")
    assert command.short_name == "FIXED_MOVE" and "short_name" in vars(command)
    assert pickle.loads(pickle.dumps(command)) == command


def test_spans_order_compare_and_hash_as_the_dataclass_did() -> None:
    from mplang.lang.diagnostics import Span, make_span
    spans = [Span("b.mp", 1), Span("a.mp", 2, 5, 9), Span("a.mp", 2, 3), Span("a.mp", 10)]
    assert sorted(spans) == [Span("a.mp", 2, 3), Span("a.mp", 2, 5, 9), Span("a.mp", 10),
                             Span("b.mp", 1)]
    assert Span("a.mp", 1) <= Span("a.mp", 1) < Span("a.mp", 1, 2) > Span("a.mp", 1)
    assert Span("a.mp", 1, 2) >= Span("a.mp", 1, 2)
    assert make_span("a.mp", 3, 4, 5) == Span("a.mp", 3, 4, 5) == Span(file="a.mp", line=3,
                                                                         col=4, end_col=5)
    assert hash(make_span("a.mp", 3)) == hash(Span("a.mp", 3, 1, None))
    assert Span("a.mp", 3) != ("a.mp", 3, 1, None)
    with pytest.raises(TypeError):
        Span("a.mp", 1) < ("a.mp", 1)  # noqa: B015
    with pytest.raises(TypeError):  # no order between an end column and none, as before
        Span("a.mp", 1, 1, 4) < Span("a.mp", 1, 1)  # noqa: B015
    assert str(Span("a.mp", 3, 4)) == "a.mp:3:4"


def test_a_replaced_profile_answers_from_its_own_fields() -> None:
    """`Catalogue.replace` and `Profile.replace` (tests build other firmwares so) give a
    profile whose remembered axis spellings are its own, not those of the one it came from;
    the profile's dict fields leave it unhashable, as the frozen dataclass was."""
    from mplang.ir.catalogue import load
    catalogue = load()
    profile = catalogue.profile
    assert profile.axis_code("X") == profile.axes["X"]  # remembered from now on
    other = catalogue.replace(profile=profile.replace(axes={**profile.axes, "X": 0x40}))
    assert other.profile.axis_code("X") == 0x40 and profile.axis_code("X") == profile.axes["X"]
    assert other.commands is catalogue.commands and other != catalogue
    assert catalogue.replace() == catalogue
    with pytest.raises(TypeError, match="unhashable"):
        hash(profile)


def test_chip_rules_compare_and_hash_by_their_numbers_only() -> None:
    """`parameters` was a `compare=False` field: rules that differ in it alone are one key
    of the virtual controller's plans; the numbers and the defaults are the dataclass's."""
    from mplang.m8194h.chipvalues import ChipRules
    plain, named = ChipRules(), ChipRules(parameters={"SET_V": {"v": "speed"}})
    assert plain == named and hash(plain) == hash(named) and len({plain, named}) == 1
    assert plain.parameters == {} and plain.parameters is not ChipRules().parameters
    assert plain != ChipRules(acceleration_rounding="down")
    assert (plain.speed_steps, plain.acceleration_divisor, plain.acceleration_max_factor,
            plain.acceleration_rounding, plain.jerk_min_factor, plain.jerk_max) == (
        8000, 64, 125, "nearest", 0.0119211, 2_000_000_000)
    assert pickle.loads(pickle.dumps(named)).parameters == named.parameters


def test_options_keep_their_defaults_and_replace_as_dataclasses_replace_did() -> None:
    from mplang.ir.lower import DEFAULT_VAR_POOL
    from mplang.ir.unit import DEFAULT_TEMPS, Options
    options = Options()
    assert (options.word_order, options.target, options.temps, options.allow_outside_includes,
            options.pins, options.var_pool) == (None, "et", DEFAULT_TEMPS, False, (),
                                                DEFAULT_VAR_POOL)
    assert options.replace(target="rs") == Options(target="rs") != options
    assert hash(Options(word_order=1)) == hash(Options(word_order=1))
