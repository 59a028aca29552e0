"""The package layout of docs/architecture.md (oracle: the import statements in the source):
module-level imports form no circle, and nothing outside ufmt.cli imports ufmt.cli."""

from __future__ import annotations

import ast
from pathlib import Path

import ufmt

ROOT = Path(ufmt.__file__).parent


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(tree: ast.AST, top_level_only: bool) -> set[str]:
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    found = set()
    for node in nodes:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("ufmt"):
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("ufmt")}
    return found


def _graph(top_level_only: bool) -> dict[str, set[str]]:
    graph = {}
    for path in ROOT.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        graph[_module(path)] = _imports(tree, top_level_only)
    return graph


def test_module_level_imports_have_no_circle():
    graph = _graph(top_level_only=True)
    state: dict[str, int] = {}  # 1 on the stack, 2 done

    def visit(node, stack):
        state[node] = 1
        for target in sorted(graph.get(node, ())):
            if target not in graph or target == "ufmt":
                continue  # the package root only re-exports
            assert state.get(target) != 1, " -> ".join([*stack, node, target])
            if target not in state:
                visit(target, [*stack, node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


def test_nothing_imports_back_into_the_cli():
    for module, targets in _graph(top_level_only=False).items():
        if not module.startswith("ufmt.cli"):
            assert not any(t.startswith("ufmt.cli") for t in targets), module
