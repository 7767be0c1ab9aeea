"""The import graph of the ``cq_fairing`` package, read from its source with :mod:`ast`.

Every import counts, at module level and inside functions alike: a cycle hidden in a
function body is still a cycle of the design.  Imports of packages outside
``cq_fairing`` (OCP, cadquery, pyvista, dask, FreeCAD) are edges out of the graph and may
be lazy.  The numerical core imports only numpy, scipy, the standard library, itself and
:mod:`cq_fairing.errors`.
"""

import ast
import sys
from pathlib import Path

import cq_fairing

PACKAGE = Path(cq_fairing.__file__).parent
CORE_MAY_IMPORT = ("numpy", "scipy", "cq_fairing.core", "cq_fairing.errors")


def module_name(path):
    """Dotted name of a source file of the package (``__init__`` names the package)."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules():
    """``{dotted name: path}`` of every module of the package."""
    return {module_name(path): path for path in PACKAGE.rglob("*.py")}


def imported_names(path):
    """``(line, dotted name)`` of everything a source file imports, at any depth.

    ``from a import b`` yields ``a.b`` (the submodule when ``b`` is one, else ``a``
    itself is what runs); relative imports are resolved against the file's package.
    """
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            found += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
    return found


def internal_target(name, modules):
    """The package module an imported dotted name runs: the longest known prefix."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph():
    """``{module: {imported package module: first line}}`` over the whole package."""
    modules = package_modules()
    graph = {}
    for name, path in modules.items():
        edges = {}
        for line, imported in imported_names(path):
            target = internal_target(imported, modules) if imported.startswith("cq_fairing") else None
            if target and target != name:
                edges.setdefault(target, line)
        graph[name] = edges
    return graph


def cycles(graph):
    """The strongly connected components of more than one module (Tarjan), sorted.

    Every import cycle lies inside one of them, so none means the graph is acyclic.
    """
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph[node]:
            if nxt not in index:
                visit(nxt)
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
                found.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph)))
    try:
        for node in sorted(graph):
            if node not in index:
                visit(node)
    finally:
        sys.setrecursionlimit(limit)
    return found


def closed_path(graph, component):
    """One cycle through the first module of a component, as ``a -> b (line) -> ... -> a``."""
    members, start = set(component), component[0]
    paths, seen = [[start]], {start}
    while paths:
        path = paths.pop(0)
        for nxt in sorted(graph[path[-1]]):
            if nxt == start:
                hops = [f"{a} (line {graph[a][b]})" for a, b in zip(path, path[1:] + [start])]
                return " -> ".join(hops + [start])
            if nxt in members and nxt not in seen:
                seen.add(nxt)
                paths.append(path + [nxt])
    raise AssertionError(f"no closed path in component {component}")


def test_the_graph_sees_function_level_imports():
    graph = import_graph()
    # cli.py imports the OCP layer only inside its commands (a lazy import)
    assert "cq_fairing.occ" in graph["cq_fairing.cli"]
    assert "cq_fairing.errors" in graph["cq_fairing.core.fairing"]


def test_the_cycle_finder_finds_a_cycle_hidden_in_a_function():
    graph = {"a": {"b": 1}, "b": {"c": 4}, "c": {"a": 9}, "d": {"a": 2}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert closed_path(graph, ["a", "b", "c"]) == "a (line 1) -> b (line 4) -> c (line 9) -> a"


def test_no_import_cycles_among_package_modules():
    graph = import_graph()
    found = [f"{closed_path(graph, component)}   [cycle through {', '.join(component)}]"
             for component in cycles(graph)]
    assert not found, "import cycles:\n" + "\n".join(found)


def test_core_imports_only_numpy_scipy_and_the_standard_library():
    allowed_top = set(sys.stdlib_module_names) | {"numpy", "scipy", "cq_fairing"}
    bad = []
    for path in sorted((PACKAGE / "core").rglob("*.py")):
        for line, imported in imported_names(path):
            top = imported.split(".")[0]
            inside = any(imported == name or imported.startswith(name + ".")
                         for name in CORE_MAY_IMPORT)
            if top not in allowed_top or (top == "cq_fairing" and not inside):
                bad.append(f"{module_name(path)} line {line}: {imported}")
    assert not bad, "the core imports outside numpy, scipy and the standard library:\n" + "\n".join(bad)
