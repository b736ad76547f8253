"""Imports between modules: no cycle among the modules of pasim_graph and pasim_blocks (lazy,
function-level imports included) and no private name imported from another module. Between
packages (the engine never imports the block library; the study never imports a command):
test_package_layers.py, on the edges found here."""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = {"pasim_graph": ROOT / "pasim_graph", "pasim_blocks": ROOT / "blocks"}


def modules() -> dict[str, Path]:
    found = {}
    for name, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((name, *parts))] = path
    return found


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, list[str], int]]:
    """(imported module, names taken from it, line) for every import in the module."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")
                up = up[: len(up) - (node.level - 1)]
                base = ".".join([*up, base] if base else up)
            names = [a.name for a in node.names]
            # ``from pkg import module`` imports the module itself.
            subs = [n for n in names if f"{base}.{n}" in known]
            out += [(f"{base}.{n}", [], node.lineno) for n in subs]
            rest = [n for n in names if n not in subs]
            if rest:
                out.append((base, rest, node.lineno))
    return out


def edges() -> list[tuple[str, str, list[str], int]]:
    known = modules()
    found = []
    for name, path in known.items():
        for target, names, line in imports(name, path, known):
            if target in known and target != name:
                found.append((name, target, names, line))
    return found


def test_no_import_cycle() -> None:
    graph = nx.DiGraph((a, b) for a, b, _, _ in edges())
    cycles = list(nx.simple_cycles(graph))
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join([*c, c[0]]) for c in cycles)


def test_no_private_name_imported_across_modules() -> None:
    private = [
        f"{a}:{line} imports {n} from {b}"
        for a, b, names, line in edges()
        for n in names
        if n.startswith("_") and not n.startswith("__")
    ]
    assert not private, "\n".join(private)


def test_the_walk_sees_lazy_imports_and_would_catch_a_cycle() -> None:
    # The checks above are only as good as the edges: a function-level import must count.
    found = {(a, b) for a, b, _, _ in edges()}
    assert ("pasim_graph.cli", "pasim_graph.studio.server") in found  # cmd_studio's lazy import
    graph = nx.DiGraph([*found, ("pasim_graph.studio.server", "pasim_graph.cli")])
    assert any(True for _ in nx.simple_cycles(graph))
