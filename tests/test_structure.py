"""The package's structure (issue #12): no import cycles, no over-long functions.

Read from the source with :mod:`ast`, so lazy imports inside functions count too.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "vesselgp"
MAX_FUNCTION_LINES = 120


def _modules():
    """Dotted module name -> source path, for every module of the package."""
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        parts = list(p.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _resolve(name, mods):
    """The longest prefix of ``name`` that is a module of the package."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def import_graph():
    """Edges module -> modules it imports (anywhere in its source), within the package."""
    mods = _modules()
    graph = {}
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"
        base = mod.split(".") if is_pkg else mod.split(".")[:-1]
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    root = ".".join(base[: len(base) - node.level + 1])
                    stem = f"{root}.{node.module}" if node.module else root
                else:
                    stem = node.module or ""
                # "from pkg import sub" imports the submodule; "from mod import name" the module
                names = [f"{stem}.{a.name}" for a in node.names]
            else:
                continue
            for n in names:
                r = _resolve(n, mods)
                if r is not None and r != mod:
                    deps.add(r)
        graph[mod] = deps
    return graph


def find_cycle(graph):
    """One import cycle as a list of modules, or None (depth-first search)."""
    state, stack = {}, []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(graph.get(m, ())):
            if state.get(d) == 1:
                return stack[stack.index(d):] + [d]
            if d not in state:
                c = visit(d)
                if c:
                    return c
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            c = visit(m)
            if c:
                return c
    return None


def test_import_graph_has_no_cycles():
    graph = import_graph()
    # the package root re-exports every stage; nothing inside the package may import it back
    importers = sorted(m for m, deps in graph.items() if "vesselgp" in deps and m != "vesselgp")
    assert importers == [], f"modules importing the package root (use vesselgp._version etc.): {importers}"
    inner = {m: {d for d in deps if d != "vesselgp"} for m, deps in graph.items() if m != "vesselgp"}
    cycle = find_cycle(inner)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    graph = import_graph()
    assert "vesselgp.fit" in graph["vesselgp.torsion"]  # lazy and top-level imports are both seen
    assert "vesselgp.errors" in graph["vesselgp.io.meshfile"]  # relative imports from a subpackage


def _long_functions():
    out = []
    for mod, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    out.append(f"{mod}.{node.name} ({n} lines)")
    return out


def test_no_function_over_120_lines():
    assert _long_functions() == []


@pytest.mark.parametrize("name", ["io", "mesh"])
def test_subpackages_are_read(name):
    assert any(m.startswith(f"vesselgp.{name}.") for m in _modules())
