"""The package layout of docs/architecture.md holds: no import circles, back ends that never
import each other, lower layers that never import higher ones, and no module over 800 lines
without a docstring saying why it must be one file. Read from the source text (imports under
`if TYPE_CHECKING:` do not run, so they do not count; every other import does, in a function
or not)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mplang"
BACK_ENDS = ("mplang.m8194h", "mplang.fatek", "mplang.csim")
LAYERS = {  # a package -> the packages it may import (besides itself)
    "mplang.lang": (),
    "mplang.ir": ("mplang.lang",),
    "mplang.family": ("mplang.lang", "mplang.ir"),
    **{b: ("mplang.lang", "mplang.ir", "mplang.family") for b in BACK_ENDS},
}
MAX_LINES = 800


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports(name: str) -> set[str]:
    """The mplang modules `name` imports when it runs."""
    path = MODULES[name]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("mplang"))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            if base.startswith("mplang"):
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    found.add(sub if sub in MODULES else base)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    found.discard(name)
    return {m for m in found if m in MODULES}


GRAPH = {name: imports(name) for name in MODULES}


def test_no_import_circles() -> None:
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def connect(node: str) -> None:  # Tarjan's strongly connected components
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in GRAPH[node]:
            if nxt not in index:
                connect(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for name in GRAPH:
        if name not in index:
            connect(name)
    assert circles == []


def _package_of(module: str) -> str | None:
    return next((p for p in sorted(LAYERS, key=len, reverse=True)
                 if module == p or module.startswith(p + ".")), None)


@pytest.mark.parametrize("name", sorted(MODULES))
def test_layers_import_only_downwards(name: str) -> None:
    package = _package_of(name)
    if package is None:  # tools, cli, the top level: anything below them
        return
    allowed = (package, *LAYERS[package], "mplang")
    wrong = sorted(m for m in GRAPH[name]
                   if not any(m == a or m.startswith(a + ".") for a in allowed[:-1])
                   and m != "mplang" and m != "mplang._moved")
    assert wrong == [], f"{name} imports {wrong}"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_modules_stay_small_or_say_why(name: str) -> None:
    path = MODULES[name]
    lines = len(path.read_text(encoding="utf-8").splitlines())
    if lines <= MAX_LINES:
        return
    docstring = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    assert "one file" in docstring, f"{path}: {lines} lines, and no word on why in one file"


def test_the_graph_sees_imports() -> None:
    """The checks above would pass on an empty graph: make sure it is not."""
    assert "mplang.m8194h.link" in GRAPH["mplang.m8194h.compiler"]
    assert "mplang.lang.rules" in GRAPH["mplang.lang.diagnostics"]
    assert "mplang.m8194h.simulate" in GRAPH["mplang.m8194h"]  # inside a function: counted
