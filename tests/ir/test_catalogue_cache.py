"""The catalogue as its cache entry holds it (mplang.ir.catalogue): each string that occurs
more than once in the TOML, and each set of scopes or targets, is one object, so the entry
is written, and unpickled by every run, with one object for each; it unpickles equal."""

from __future__ import annotations

import pickle
import pickletools
import tomllib

import pytest

from mplang.ir import catalogue


@pytest.fixture
def built(monkeypatch: pytest.MonkeyPatch) -> catalogue.Catalogue:
    monkeypatch.setattr(catalogue, "BUILDS", [])
    return catalogue._build("m8194h", catalogue._read_text("m8194h", "commands.toml"),
                            catalogue._read_text("m8194h", "device.toml"))


def test_repeated_strings_and_sets_are_one_object_each(built: catalogue.Catalogue) -> None:
    params = [param for command in built.commands for param in command.params]
    for values in ([p.type for p in params], [p.kind for p in params],
                   [p.doc for p in params], [c.section for c in built.commands],
                   [c.targets for c in built.commands], [c.scope for c in built.commands]):
        assert len({id(value) for value in values}) == len(set(values))


def test_the_entry_unpickles_equal_with_one_object_a_distinct_string(
        built: catalogue.Catalogue) -> None:
    entry = pickle.dumps(built, pickle.HIGHEST_PROTOCOL)
    assert pickle.loads(entry) == built
    strings = [arg for op, arg, _ in pickletools.genops(entry) if "UNICODE" in op.name]
    assert len(strings) == len(set(strings))


def test_the_parsed_values_are_those_of_the_toml(built: catalogue.Catalogue) -> None:
    raw = tomllib.loads(catalogue._read_text("m8194h", "device.toml"))
    assert built.profile.raw == raw
    names = [c["name"] for c in tomllib.loads(
        catalogue._read_text("m8194h", "commands.toml"))["command"]]
    assert [c.name for c in built.commands] == names
