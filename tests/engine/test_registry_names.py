"""The registry keeps type names in its own table: registering a library class under a second
name does not rename the library's class, and each name lists and builds as itself."""

from __future__ import annotations

from importlib.metadata import EntryPoint

import pytest

from pasim_graph import block, registry

PENCIL = "pasim_blocks.antennas.pencil:PencilBeamAntenna"


@pytest.fixture
def second_name(monkeypatch: pytest.MonkeyPatch):
    real = dict(registry._entry_points())
    alias = EntryPoint("zz_plugin.pencil", PENCIL, registry.GROUP)
    registry._loaded.clear()
    monkeypatch.setattr(registry, "_entry_points", lambda: {**real, alias.name: alias})
    monkeypatch.setattr(block, "TYPE_NAMES", dict(block.TYPE_NAMES))
    monkeypatch.setattr(registry, "TYPE_NAMES", block.TYPE_NAMES)
    yield
    registry._loaded.clear()  # before the real table and entry points come back


@pytest.mark.parametrize("first", ["antenna.pencil", "zz_plugin.pencil"])
def test_a_second_name_does_not_rename_the_class(second_name, first: str) -> None:
    block.TYPE_NAMES.clear()
    other = "zz_plugin.pencil" if first == "antenna.pencil" else "antenna.pencil"
    cls = registry.get(first)
    assert cls is not None and cls.type_name == first
    assert registry.get(other) is cls
    assert cls.type_name == first  # not renamed by the second registration
    assert cls.interface(other)["type"] == other
    assert {n: c.interface(n)["type"] for n, c in registry.all_blocks().items()}[other] == other
    assert "type_name" not in vars(cls)  # nothing written on the class


def test_blocks_carry_the_name_their_graph_gave_them(second_name) -> None:
    from pasim_graph.graph import resolve

    from ..conftest import GRAPHS

    text = (GRAPHS / "generic_radar.yaml").read_text().replace("antenna.pencil", "zz_plugin.pencil")
    assert "zz_plugin.pencil" in text
    from pasim_graph.graphfile import parse

    graph = resolve(parse(text)).graph
    built = graph.build()
    (antenna,) = [b for b in built.values() if type(b).__name__ == "PencilBeamAntenna"]
    assert antenna.type_name == "zz_plugin.pencil"
