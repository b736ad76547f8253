"""Packages import downward only: the engine, the library's shared modules, then the signal
chain in the order the signal flows, then the study, then the commands. No package imports a
package above it (the study never imports a command), and no two packages import each other
through any path, lazy function-level imports included.

The layer order is written here once (docs/concepts.md refers to it). A package new to the
library must be placed in it: the test fails for a package it does not know.
"""

from __future__ import annotations

from functools import lru_cache

import networkx as nx

from .test_imports import ROOT
from .test_imports import edges as module_edges


@lru_cache(maxsize=1)
def edges() -> tuple[tuple[str, str, list[str], int], ...]:
    """Every module import of both packages (parsed once for the module's tests)."""
    return tuple(module_edges())


#: Lowest first. A package may import packages of lower layers only; the library's top-level
#: modules (``signals``, ``angles``, ``timing``: what several subsystems share) count as one
#: package, ``pasim_blocks``.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("pasim_graph",),
    ("pasim_blocks",),
    ("pasim_blocks.waveforms",),
    ("pasim_blocks.transmitters",),
    ("pasim_blocks.antennas",),
    ("pasim_blocks.truth",),
    ("pasim_blocks.scans",),
    ("pasim_blocks.propagation",),
    ("pasim_blocks.weather",),
    ("pasim_blocks.receivers",),
    ("pasim_blocks.processing",),
    ("pasim_blocks.algorithms",),
    ("pasim_blocks.products",),
    ("pasim_blocks.study",),
    ("pasim_blocks.commands",),
)
LAYER = {package: i for i, names in enumerate(LAYERS) for package in names}


def package_of(module: str) -> str:
    """The package a module counts under: the engine is one package, the library one per
    subpackage, its top-level modules the package ``pasim_blocks``."""
    parts = module.split(".")
    if parts[0] == "pasim_graph":
        return "pasim_graph"
    if len(parts) > 1 and (ROOT / "blocks" / parts[1]).is_dir():
        return f"pasim_blocks.{parts[1]}"
    return "pasim_blocks"


def package_edges(
    found: tuple[tuple[str, str, list[str], int], ...],
) -> dict[tuple[str, str], list[str]]:
    """(importer, imported) package pairs, each with the module lines that make it."""
    out: dict[tuple[str, str], list[str]] = {}
    for a, b, _, line in found:
        pa, pb = package_of(a), package_of(b)
        if pa != pb:
            out.setdefault((pa, pb), []).append(f"{a}:{line} imports {b}")
    return out


def upward(pairs: dict[tuple[str, str], list[str]]) -> list[str]:
    """Every import of a package at the same layer or above the importer's."""
    return [
        where for (a, b), lines in sorted(pairs.items()) if LAYER[b] >= LAYER[a] for where in lines
    ]


def cycles(pairs: dict[tuple[str, str], list[str]]) -> list[list[str]]:
    return list(nx.simple_cycles(nx.DiGraph(list(pairs))))


def test_every_package_has_a_layer() -> None:
    pairs = package_edges(edges())
    found = {p for pair in pairs for p in pair}
    assert not found - set(LAYER), f"packages without a layer: {sorted(found - set(LAYER))}"
    # Every subpackage of the library, imported or not.
    folders = {
        f"pasim_blocks.{d.name}"
        for d in (ROOT / "blocks").iterdir()
        if (d / "__init__.py").is_file()
    }
    assert not folders - set(LAYER), f"packages without a layer: {sorted(folders - set(LAYER))}"


def test_no_package_imports_a_package_above_it() -> None:
    """The engine (layer 0) imports nothing of the library; the study imports no command."""
    wrong = upward(package_edges(edges()))
    assert not wrong, "imports that run up the layers:\n" + "\n".join(wrong)


def test_no_cycle_between_packages() -> None:
    found = cycles(package_edges(edges()))
    assert not found, "package cycles:\n" + "\n".join(" -> ".join([*c, c[0]]) for c in found)


def test_the_checks_would_catch_a_study_importing_a_command() -> None:
    # The layer and cycle checks are only as good as the edges they see: one lazy import of
    # a command from the study (as main had before issue 37) must trip both.
    back = ("pasim_blocks.study.hardware", "pasim_blocks.commands.pattern", ["measure"], 96)
    pairs = package_edges((*edges(), back))
    assert upward(pairs) == ["pasim_blocks.study.hardware:96 imports pasim_blocks.commands.pattern"]
    assert ["pasim_blocks.commands", "pasim_blocks.study"] in [sorted(c) for c in cycles(pairs)]
