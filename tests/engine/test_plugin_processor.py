"""A plugin processor written on the declared base alone (``pasim_blocks.processing.
moment_processor.MomentProcessor``), the one of docs/writing-blocks.md taken from the page as
written: it has the family's ports and thresholds without declaring them, the registry and
the validator read them from the class, and its reflectivity is the pulse-pair processor's to
the bit (both are the noise-corrected lag-0 power of H through the same last step)."""

from __future__ import annotations

import re
import sys
import types
from importlib.metadata import EntryPoint
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.processing.moment_processor import MomentProcessor
from pasim_blocks.processing.pulse_pair import PulsePairProcessor

from pasim_graph import Chunk, block, registry

from ..conftest import GRAPHS, pasim

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-blocks.md"
GUIDE_MODULE = "guide_reflectivity"
NAME = "zz_plugin.reflectivity"


def guide_module() -> types.ModuleType:
    """The module ``my_radar_blocks/reflectivity.py`` of docs/writing-blocks.md, as written."""
    if GUIDE_MODULE not in sys.modules:
        text = GUIDE.read_text()
        start = text.index("`my_radar_blocks/reflectivity.py`")
        match = re.compile(r"```python\n(.*?)```", re.S).search(text, start)
        assert match, "the guide's reflectivity processor"
        module = types.ModuleType(GUIDE_MODULE)
        exec(compile(match.group(1), f"{GUIDE}:reflectivity.py", "exec"), module.__dict__)
        sys.modules[GUIDE_MODULE] = module
    return sys.modules[GUIDE_MODULE]


@pytest.fixture
def plugin(monkeypatch: pytest.MonkeyPatch):
    """The guide's processor registered in ``pasim_graph.blocks``, in this process."""
    guide_module()
    real = dict(registry._entry_points())
    ours = {NAME: EntryPoint(NAME, f"{GUIDE_MODULE}:Reflectivity", registry.GROUP)}
    registry._loaded.clear()
    registry._errors.clear()
    monkeypatch.setattr(registry, "_entry_points", lambda: {**real, **ours})
    monkeypatch.setattr(block, "TYPE_NAMES", dict(block.TYPE_NAMES))
    monkeypatch.setattr(registry, "TYPE_NAMES", block.TYPE_NAMES)
    yield
    registry._loaded.clear()
    registry._errors.clear()


def test_the_guides_processor_has_the_familys_declarations(plugin) -> None:
    cls = registry.get(NAME)
    assert cls is guide_module().Reflectivity and issubclass(cls, MomentProcessor)
    assert list(cls.inputs) == list(MomentProcessor.inputs)
    assert list(cls.params) == list(MomentProcessor.params)
    assert cls.outputs["moments"].fields == ("DBZH",)
    assert [p["name"] for p in cls.interface()["inputs"]] == list(MomentProcessor.inputs)


def inputs(seed: int) -> dict:
    """Two beams of 50 gates of 16 pulses of complex Gaussian I/Q over a noise of 1 W."""
    rng = np.random.default_rng(seed)
    shape = (2, 50, 16, 2)
    power = rng.uniform(0.5, 20.0, shape[:2])[..., None, None]
    iq = (rng.normal(size=shape) + 1j * rng.normal(size=shape)) * np.sqrt(power / 2)
    gates = 100.0 + 250.0 * np.arange(shape[1])
    cal = xr.Dataset(
        {"radar_constant_db": (("beam", "polarization"), np.full((2, 2), -60.0))},
        coords={"range": ("range", gates)},
        attrs={"wavelength_m": 0.107, "blind_range_m": 0.0, "calibration": "test"},
    )
    return {
        "iq": iq.astype(np.complex64),
        "noise_power": np.ones((*shape[:2], 2)),
        "calibration": cal,
        "beams": xr.Dataset({"prt": ("beam", [1e-3, 1e-3])}),
    }


def test_its_reflectivity_is_the_pulse_pairs_to_the_bit(plugin) -> None:
    cls = registry.get(NAME)
    assert cls is not None
    data, chunk = inputs(3), Chunk(beams=np.arange(2))
    ours = cls(name="p").process(data, chunk)["moments"]
    theirs = PulsePairProcessor(name="p").process(data, chunk)["moments"]
    assert set(ours.data_vars) == {"DBZH", "nyquist_velocity"}
    np.testing.assert_array_equal(ours["DBZH"].values, theirs["DBZH"].values)
    assert np.isfinite(ours["DBZH"].values).sum() > 50
    assert ours["DBZH"].attrs == theirs["DBZH"].attrs


def test_the_validator_reads_the_plugins_ports(plugin, tmp_path, capsys) -> None:
    """In a graph in the place of processor.pulse_pair: valid without the expected-level
    input (which the base does not declare); the input named is refused."""
    text = (GRAPHS / "uniform_ideal.yaml").read_text()
    line = next(t for t in text.splitlines() if t.lstrip().startswith("ppp:"))
    text = text.replace(line, f"  ppp:      {{type: {NAME}}}")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    code, err = pasim(capsys, "validate", str(bad))
    assert code == 2 and "echo_correlations" in err and "Traceback" not in err
    good = tmp_path / "good.yaml"
    good.write_text(text.replace("  - weather.echo_correlations -> ppp.echo_correlations\n", ""))
    code, err = pasim(capsys, "validate", str(good))
    assert code == 0, err
