"""docs/writing-blocks.md's worked plugin runs as written: its two modules are extracted
from the page, imported, built and run on a chunk of I/Q."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import numpy as np

from pasim_graph import Chunk

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-blocks.md"


def snippet(after: str) -> str:
    """The first ```python block after the line naming the module."""
    text = GUIDE.read_text()
    start = text.index(after)
    match = re.compile(r"```python\n(.*?)```", re.S).search(text, start)
    assert match, after
    return match.group(1)


def load(name: str, code: str, tmp_path: Path):
    path = tmp_path / f"{name}.py"
    path.write_text(code)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def test_the_guides_plugin_runs_as_written(tmp_path: Path) -> None:
    radome = load("guide_radome", snippet("`my_radar_blocks/radome.py`:"), tmp_path)
    noise = load("guide_phase_noise", snippet("`my_radar_blocks/phase_noise.py`"), tmp_path)
    rng = np.random.default_rng(0)
    iq = (rng.standard_normal((2, 5, 8, 2)) + 1j * rng.standard_normal((2, 5, 8, 2))).astype(
        np.complex64
    )
    chunk = Chunk(beams=np.arange(2), block_name="noise", seed=1)
    out = radome.Attenuator(name="radome", loss_db=6.0).process({"iq_in": iq}, chunk)["iq"]
    assert out.dtype == np.complex64
    np.testing.assert_allclose(np.abs(out), np.abs(iq) * 10 ** (-6 / 20), rtol=1e-6)
    noisy = noise.PhaseNoise(name="noise", rms_deg=5.0).process({"iq_in": iq}, chunk)["iq"]
    assert noisy.dtype == np.complex64 and noisy.shape == iq.shape
    np.testing.assert_allclose(np.abs(noisy), np.abs(iq), rtol=1e-5)
    assert not np.allclose(noisy, iq)
