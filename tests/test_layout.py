"""The house plan of docs/architecture.md, enforced on the source (oracle: the import
statements, function and module sizes as the parser reads them).

The layer table is read from the document itself (between its ``layers:begin`` and
``layers:end`` markers), so the page and the check cannot drift apart. Every import between
ufmt modules, at module level or inside a function, must go to the importer's own layer or a
lower one; the one exception the document names (a result's ``plot``/``save`` method importing
``ufmt.plots``) is allowed only inside a function of that name. No circle between modules, no
``_private`` name imported from another module, no module over the size limit, no function
over the length limit.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

import ufmt

PACKAGE = Path(ufmt.__file__).parent
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"
MAX_MODULE_LINES = 700
MAX_FUNCTION_LINES = 80
LATE_PLOT_METHODS = {"plot", "save"}  # a result's method may import ufmt.plots when called


def layer_table(text: str) -> list[tuple[str, tuple[str, ...]]]:
    """(layer name, module prefixes) from the document's marked table, lowest layer first."""
    block = text.split("<!-- layers:begin -->")[1].split("<!-- layers:end -->")[0]
    rows = []
    for line in block.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not cells[1].startswith("`"):
            continue  # header, rule or prose
        rows.append((cells[0], tuple(re.findall(r"`(ufmt[\w.]*)`", cells[1]))))
    return rows


@dataclass(frozen=True)
class Import:
    importer: str  # dotted module name
    target: str  # dotted module name (or "ufmt" for a name the package root re-exports)
    names: tuple[str, ...]  # names taken from the target ("" for `import x`)
    function: str | None  # innermost enclosing function, None at module level
    line: int


def module_name(path: Path, root: Path = PACKAGE) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(dotted: str, root: Path) -> bool:
    base = root.parent.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def imports_of(source: str, importer: str, root: Path = PACKAGE) -> list[Import]:
    """Every import of a ufmt module in ``source`` (the module ``importer``)."""
    found: list[Import] = []

    def visit(node: ast.AST, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            inner = function
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                inner = child.name
            if isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                if child.module.split(".")[0] == "ufmt":
                    for alias in child.names:
                        sub = f"{child.module}.{alias.name}"
                        if _is_module(sub, root):
                            found.append(Import(importer, sub, ("",), inner, child.lineno))
                        else:
                            found.append(
                                Import(importer, child.module, (alias.name,), inner, child.lineno)
                            )
            elif isinstance(child, ast.Import):
                for alias in child.names:
                    if alias.name.split(".")[0] == "ufmt":
                        found.append(Import(importer, alias.name, ("",), inner, child.lineno))
            visit(child, inner)

    visit(ast.parse(source), None)
    return found


def layer_of(module: str, table) -> int | None:
    """Index of the layer whose longest prefix matches ``module`` (None: not in the table)."""
    best, best_len = None, -1
    for index, (_, prefixes) in enumerate(table):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best_len:
                best, best_len = index, len(prefix)
    return best


def layer_violations(found: list[Import], table) -> list[str]:
    """Imports that go up the table (the named late-plot exception allowed)."""
    problems = []
    for imp in found:
        if "ufmt" in (imp.importer, imp.target):
            continue  # the package root re-exports the API and is loaded by every import
        own, other = layer_of(imp.importer, table), layer_of(imp.target, table)
        if own is None or other is None:
            problems.append(f"{imp.importer}:{imp.line}: {imp.target} has no layer in the table")
        elif other > own:
            late_plot = imp.function in LATE_PLOT_METHODS and imp.target.startswith("ufmt.plots")
            if not late_plot:
                where = f"in {imp.function}()" if imp.function else "at module level"
                problems.append(
                    f"{imp.importer}:{imp.line} ({table[own][0]}) imports {imp.target} "
                    f"({table[other][0]}) {where}"
                )
    return problems


def circles(found: list[Import]) -> list[str]:
    """Import circles between modules (every import, module level and late)."""
    graph: dict[str, set[str]] = {}
    for imp in found:
        if imp.target != "ufmt" and imp.target != imp.importer:
            graph.setdefault(imp.importer, set()).add(imp.target)
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    problems = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                path = [*stack, node]
                problems.append(" -> ".join([*path[path.index(target) :], target]))
            elif target not in state:
                visit(target, [*stack, node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    return problems


def _all_imports() -> list[Import]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        found += imports_of(path.read_text(encoding="utf-8"), module_name(path))
    return found


TABLE = layer_table(ARCHITECTURE.read_text(encoding="utf-8"))


def test_the_document_has_a_layer_table_covering_every_module():
    assert [name for name, _ in TABLE][:2] == ["base", "model"]
    modules = [module_name(p) for p in PACKAGE.rglob("*.py")]
    missing = [m for m in modules if m != "ufmt" and layer_of(m, TABLE) is None]
    assert not missing, f"modules without a layer in docs/architecture.md: {missing}"


def test_no_import_goes_up_a_layer():
    problems = layer_violations(_all_imports(), TABLE)
    assert not problems, "\n".join(problems)


def test_no_circle_between_modules():
    problems = circles(_all_imports())
    assert not problems, "\n".join(problems)


def test_no_private_name_imported_from_another_module():
    private = [
        f"{i.importer}:{i.line} imports {name} from {i.target}"
        for i in _all_imports()
        for name in i.names
        if name.startswith("_") and not name.startswith("__")
    ]
    assert not private, "\n".join(private)


def test_modules_and_functions_stay_short():
    long = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if text.count("\n") > MAX_MODULE_LINES:
            long.append(f"{module_name(path)}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long.append(f"{module_name(path)}.{node.name}: {length} lines")
    assert not long, "\n".join(long)


def test_no_tracker_numbers_in_code_or_docs():
    root = PACKAGE.parent
    paths = [*PACKAGE.rglob("*.py"), *root.joinpath("tests").rglob("*.py")]
    paths += [*root.joinpath("benchmarks").rglob("*.py"), *root.joinpath("docs").rglob("*.md")]
    pattern = re.compile(r"\bissues? #?\d+\b", re.IGNORECASE)
    hits = [
        f"{p.relative_to(root)}:{n}"
        for p in paths
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert not hits, "\n".join(hits)


def independence_violations(found: list[Import], pairs) -> list[str]:
    """Imports between two packages that must stay independent (either direction)."""
    return [
        f"{imp.importer}:{imp.line} imports {imp.target}"
        for imp in found
        for a, b in pairs
        for own, other in ((a, b), (b, a))
        if (imp.importer == own or imp.importer.startswith(own + "."))
        and (imp.target == other or imp.target.startswith(other + "."))
    ]


# the MSTMM and its oracle, the assembled model, share only the layers above both
INDEPENDENT = [("ufmt.mstmm", "ufmt.assembled")]


def test_the_mstmm_and_the_assembled_model_import_nothing_from_each_other():
    problems = independence_violations(_all_imports(), INDEPENDENT)
    assert not problems, "\n".join(problems)


# The checker itself must be able to fail: synthetic modules breaking each rule.


def test_the_checker_reports_an_import_between_independent_packages():
    source = "def solve():\n    from ufmt.assembled import assembled_modes\n"
    found = imports_of(source, "ufmt.mstmm.solve")
    assert independence_violations(found, INDEPENDENT) == [
        "ufmt.mstmm.solve:2 imports ufmt.assembled"
    ]


def test_the_checker_reports_a_late_import_up_a_layer():
    source = "def heights():\n    from ufmt.machining.cutting import tool_tip\n"
    problems = layer_violations(imports_of(source, "ufmt.model.machine"), TABLE)
    assert len(problems) == 1 and "in heights()" in problems[0]


def test_the_checker_allows_the_late_plot_import_only_in_plot_methods():
    allowed = "class R:\n    def plot(self):\n        from ufmt.plots.surface import f\n"
    assert not layer_violations(imports_of(allowed, "ufmt.simulate"), TABLE)
    other = "def run():\n    from ufmt.plots.surface import f\n"
    assert layer_violations(imports_of(other, "ufmt.simulate"), TABLE)


def test_the_checker_finds_a_circle():
    found = [
        Import("ufmt.a", "ufmt.b", ("",), None, 1),
        Import("ufmt.b", "ufmt.c", ("",), "f", 1),
        Import("ufmt.c", "ufmt.a", ("",), None, 1),
    ]
    assert circles(found) == ["ufmt.a -> ufmt.b -> ufmt.c -> ufmt.a"]


@pytest.mark.parametrize("module", ["ufmt.cli", "ufmt.cli.modes"])
def test_nothing_below_the_cli_imports_it(module):
    source = f"import {module}\n"
    assert layer_violations(imports_of(source, "ufmt.report"), TABLE)
