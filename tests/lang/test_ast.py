"""The syntax tree's classes are written out instead of made by `@dataclass`: each one's
annotations, `_fields`, `__match_args__` and `__init__` parameters must name the same fields
in the same order, or equality, repr, `replace` and pattern matching would silently skip one."""

from __future__ import annotations

import inspect

import pytest

from mplang.lang import ast

NODES = sorted((cls for cls in vars(ast).values() if inspect.isclass(cls)
                and issubclass(cls, ast._Record) and cls is not ast._Record),
               key=lambda cls: cls.__name__)


def test_every_node_class_is_checked() -> None:
    assert len(NODES) >= 40


@pytest.mark.parametrize("node", NODES, ids=lambda cls: cls.__name__)
def test_fields_annotations_and_init_agree(node: type[ast._Record]) -> None:
    annotated = tuple(name for name in node.__annotations__ if not name.startswith("_"))
    parameters = tuple(inspect.signature(node.__init__).parameters)[1:]
    assert node._fields == annotated == parameters
    assert node.__match_args__ == node._fields


@pytest.mark.parametrize("node", NODES, ids=lambda cls: cls.__name__)
def test_init_sets_every_field_and_replace_copies_them(node: type[ast._Record]) -> None:
    values = {name: (name, index) for index, name in enumerate(node._fields)}
    made = node(**values)
    assert {name: getattr(made, name) for name in node._fields} == values
    first = node._fields[0]
    changed = made.replace(**{first: "other"})
    assert getattr(changed, first) == "other" and changed != made
    assert made.replace() == made and made.replace() is not made
    assert repr(made).startswith(f"{node.__qualname__}({first}=")
