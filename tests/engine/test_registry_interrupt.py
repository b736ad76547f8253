"""Ctrl-C while a block type's module is imported is an interrupt, not a broken plugin.

A compiled module's initialisation turns the interrupt into its ImportError (pybind11's
"initialization failed", raised from the KeyboardInterrupt): `pasim study` interrupted as it
loaded the 10 m CPPAR's blocks listed `channel.weather` as "registered but failed to load" and
every graph problem that followed, instead of "interrupted".
"""

from __future__ import annotations

import warnings
from importlib.metadata import EntryPoint

import pytest

from pasim_graph import registry

PENCIL = "pasim_blocks.antennas.pencil:PencilBeamAntenna"


class Interrupted:
    value = "zz_plugin.compiled:Block"

    def __init__(self, cause: BaseException):
        self.cause = cause

    def load(self):
        raise ImportError("initialization failed") from self.cause


@pytest.fixture
def plugin(monkeypatch: pytest.MonkeyPatch):
    real = dict(registry._entry_points())
    table: dict = {}
    registry._loaded.clear()
    monkeypatch.setattr(registry, "_entry_points", lambda: {**real, **table})
    yield table
    registry._loaded.clear()
    registry._errors.clear()


def test_an_interrupted_import_is_an_interrupt(plugin):
    plugin["zz.compiled"] = Interrupted(KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        registry.get("zz.compiled")
    # Not remembered as broken: the next try imports it.
    plugin["zz.compiled"] = EntryPoint("zz.compiled", PENCIL, registry.GROUP)
    cls = registry.get("zz.compiled")
    assert cls is not None and cls.__name__ == "PencilBeamAntenna"
    assert registry.load_error("zz.compiled") is None


def test_a_broken_import_still_only_warns(plugin):
    plugin["zz.compiled"] = Interrupted(OSError("libfoo.so: cannot open shared object file"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert registry.get("zz.compiled") is None
    assert "initialization failed" in registry.load_error("zz.compiled")
    assert any("failed to load" in str(w.message) for w in caught)
