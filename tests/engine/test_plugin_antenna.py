"""A plugin antenna written against the declared base alone (``pasim_blocks.antennas.antenna``:
``Antenna`` and ``DualPolField``), the one of docs/writing-blocks.md taken from the page as
written, works with ``pasim pattern``, ``pasim run`` and ``pasim study``; one that leaves out
a method of the base is refused when the registry loads it, naming the method; a command
plugin that is not a ``Command`` is refused naming what it lacks.

The antenna: a square array of N x N isotropic elements half a wavelength apart, uniform
weights, mechanically steered. Its one-way field in the antenna's direction cosines (u, v) is
AF(u) AF(v), AF(u) = sin(N pi u / 2) / (N sin(pi u / 2)). What each test holds it to, computed
here from that formula and nothing of the library:

* the 3-dB beamwidth of the azimuth cut, 2 asin(u_3), AF(u_3)^2 = 1/2 (0.01 deg);
* the first sidelobe, the peak of AF^2 between its first two nulls, u = 2/N and 4/N (-13.2 dB
  for N = 24; 0.05 dB);
* the broadside two-way solid angle of the pattern port, the integral of (AF(u) AF(v))^4 over
  the grid's directions (1 %);
* the beamwidth a study measures for its sidelobe-free stand-in (1 %).
"""

from __future__ import annotations

import json
import math
import re
import sys
import types
from importlib.metadata import EntryPoint
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.antennas.antenna import Antenna
from scipy.optimize import brentq, minimize_scalar

from pasim_graph import Chunk, block, registry
from pasim_graph.command_api import Command
from pasim_graph.contracts import ScoringCommand

from ..conftest import FIXTURES, pasim, pasim_out

N = 24
SQUARE = "zz_plugin.square"
NO_GAIN = "zz_plugin.no_gain"
GUIDE = Path(__file__).resolve().parents[2] / "docs" / "writing-blocks.md"
GUIDE_MODULE = "guide_square_array"


def array_factor(u: Any) -> Any:
    """AF(u) of N elements half a wavelength apart (np.sinc(x) = sin(pi x) / (pi x))."""
    u = np.asarray(u, dtype=float)
    return np.sinc(N * u / 2) / np.sinc(u / 2)


def guide_module() -> types.ModuleType:
    """The module ``my_radar_blocks/square_array.py`` of docs/writing-blocks.md, as written
    there (kept in ``sys.modules`` so that an entry point can name it)."""
    if GUIDE_MODULE not in sys.modules:
        text = GUIDE.read_text()
        start = text.index("`my_radar_blocks/square_array.py`")
        match = re.compile(r"```python\n(.*?)```", re.S).search(text, start)
        assert match, "the guide's square array"
        module = types.ModuleType(GUIDE_MODULE)
        exec(compile(match.group(1), f"{GUIDE}:square_array.py", "exec"), module.__dict__)
        sys.modules[GUIDE_MODULE] = module
    return sys.modules[GUIDE_MODULE]


class NoGain(Antenna):
    """Written against the base but without ``pattern_gain_db``."""

    def broadside(self) -> tuple[float, float]:
        return 0.0, 0.0

    def fields_at(self, steer_az_deg, steer_el_deg, az_deg, el_deg, seed=0, resource=None):
        raise AssertionError("never called: the registry refuses the class")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        raise AssertionError("never called: the registry refuses the class")


class NoRun:
    help = "a command without run"

    def configure(self, parser: Any) -> None:
        pass


class Fine:
    help = "a command"

    def configure(self, parser: Any) -> None:
        pass

    def run(self, args: Any) -> int:
        return 0


NO_RUN = NoRun()
FINE = Fine()


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch):
    """The two antennas registered in ``pasim_graph.blocks`` (as a plugin package's entry
    points would), in this process."""
    guide_module()
    real = dict(registry._entry_points())
    ours = {
        SQUARE: EntryPoint(SQUARE, f"{GUIDE_MODULE}:SquareArray", registry.GROUP),
        NO_GAIN: EntryPoint(NO_GAIN, f"{__name__}:NoGain", registry.GROUP),
    }
    registry._loaded.clear()
    registry._errors.clear()
    monkeypatch.setattr(registry, "_entry_points", lambda: {**real, **ours})
    monkeypatch.setattr(block, "TYPE_NAMES", dict(block.TYPE_NAMES))
    monkeypatch.setattr(registry, "TYPE_NAMES", block.TYPE_NAMES)
    yield
    registry._loaded.clear()  # before the real table and entry points come back
    registry._errors.clear()


def graph_with(tmp_path: Path, antenna: str) -> Path:
    """The small pencil-beam graph of the study fixtures (8 pulses) with ``antenna``."""
    text = (FIXTURES / "study" / "small_pencil.yaml").read_text()
    line = next(t for t in text.splitlines() if t.lstrip().startswith("antenna:"))
    path = tmp_path / "plugin_radar.yaml"
    path.write_text(text.replace(line, f"  antenna:  {{type: {antenna}}}"))
    return path


def beamwidth_deg() -> float:
    u3 = brentq(lambda u: array_factor(u) ** 2 - 0.5, 1e-9, 2.0 / N)
    return float(np.rad2deg(2 * np.arcsin(u3)))


def first_sidelobe_db() -> float:
    best = minimize_scalar(
        lambda u: -(array_factor(u) ** 2), bounds=(2.0 / N, 4.0 / N), method="bounded"
    )
    return float(10 * np.log10(-best.fun))


def test_pasim_pattern_measures_the_plugin_antenna(plugins, tmp_path, capsys) -> None:
    code, out, err = pasim_out(capsys, "pattern", str(graph_with(tmp_path, SQUARE)), "--json")
    assert code == 0, err
    figures = json.loads(out)
    assert figures["type"] == SQUARE
    assert figures["beamwidth_az_deg"] == pytest.approx(beamwidth_deg(), abs=0.01)
    assert figures["beamwidth_el_deg"] == pytest.approx(beamwidth_deg(), abs=0.01)
    assert figures["first_sidelobe_db"] == pytest.approx(first_sidelobe_db(), abs=0.05)
    assert figures["zdr_bias_db"] == pytest.approx(0.0, abs=1e-9)
    assert figures["electronics"] == "ideal"  # the base's ideal_copy: no errors to leave out


def test_the_sampled_pattern_is_the_formula(plugins) -> None:
    square = guide_module().SquareArray
    assert square.params["elements"].default == N
    antenna = square(name="antenna")
    beams = xr.Dataset({"azimuth": ("beam", [280.0, 281.0]), "elevation": ("beam", [0.5, 0.5])})
    ds = antenna.process({"beams": beams}, Chunk(beams=np.arange(2)))["pattern"]
    assert ds["power"].sizes["beam"] == 2
    peak = ds["power"].sel(polarization="H").isel(beam=0).values.max()
    assert peak == pytest.approx(1.0, abs=1e-6)
    # The broadside two-way solid angle, integrated here on a grid ten times finer.
    d = np.deg2rad(np.linspace(-10, 10, 2001))
    az, el = np.meshgrid(d, d)
    x, z = np.cos(el) * np.sin(az), np.sin(el)
    power = (array_factor(x) * array_factor(z)) ** 2
    omega = float(np.sum(power**2 * np.cos(el)) * (d[1] - d[0]) ** 2)
    assert ds.attrs["two_way_solid_angle_sr_H"] == pytest.approx(omega, rel=0.01)
    assert ds.attrs["gain_db"] == pytest.approx(10 * math.log10(math.pi * N**2))


def test_pasim_run_with_the_plugin_antenna(plugins, tmp_path, capsys) -> None:
    out = tmp_path / "run.zarr"
    graph = graph_with(tmp_path, SQUARE)
    code, err = pasim(capsys, "run", str(graph), "--sector", "282:285", "--out", str(out))
    assert code == 0, err
    dbz = xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()["DBZH"].values
    assert dbz.shape[0] == 3
    finite = dbz[np.isfinite(dbz)]
    assert finite.size > 100 and -40 < np.median(finite) < 80


def test_a_study_of_the_plugin_antenna(plugins, tmp_path, capsys) -> None:
    graph = graph_with(tmp_path, SQUARE)
    study = tmp_path / "square_study.yaml"
    study.write_text(
        "format: pasim-study/1\n"
        "title: the plugin antenna on a few degrees of the bundled scene\n"
        f"systems:\n  - {{name: square, graph: {graph.name}}}\n"
        'cases:\n  - {name: convective, truth: "", sector: "282:285", elevation: 0.5}\n'
        "seeds: [0]\n"
    )
    out = tmp_path / "out"
    code, err = pasim(capsys, "study", str(study), "--out", str(out), "--no-report")
    assert code == 0, err
    scores = json.loads((out / "scores.json").read_text())
    assert "square" in scores
    beamwidths = scores["_study"]["beamwidths_deg"]
    assert beamwidths["square/convective/-"] == pytest.approx(beamwidth_deg(), rel=0.01)


def test_an_antenna_missing_a_method_is_refused_naming_it(plugins, tmp_path, capsys) -> None:
    with pytest.warns(registry.PluginWarning, match="pattern_gain_db") as caught:
        assert registry.get(NO_GAIN) is None
    (message,) = [str(w.message) for w in caught]
    assert "Antenna" in message and "fields_at" not in message  # only what is missing
    assert registry.get(SQUARE) is guide_module().SquareArray
    code, err = pasim(capsys, "validate", str(graph_with(tmp_path, NO_GAIN)))
    assert code == 2
    assert "block 'antenna'" in err and "pattern_gain_db" in err and "Traceback" not in err


def test_a_command_is_checked_against_the_protocol(monkeypatch) -> None:
    real = registry.entry_points

    def with_ours(group: str) -> list[EntryPoint]:
        found = list(real(group=group))
        if group == registry.COMMANDS:
            found += [
                EntryPoint("zz_no_run", f"{__name__}:NO_RUN", group),
                EntryPoint("zz_fine", f"{__name__}:FINE", group),
            ]
        return found

    monkeypatch.setattr(registry, "entry_points", with_ours)
    registry.commands.cache_clear()
    try:
        with pytest.warns(registry.PluginWarning, match="has no 'run'"):
            found = registry.commands()
        assert "zz_no_run" not in found and found["zz_fine"] is FINE
        assert isinstance(FINE, Command) and not isinstance(NO_RUN, Command)
        assert all(isinstance(c, Command) for c in found.values())
    finally:
        registry.commands.cache_clear()


def test_pasim_score_against_needs_a_scoring_compare_command(monkeypatch, capsys) -> None:
    """``pasim score --against`` reaches the library's ``compare`` command through the declared
    ScoringCommand contract: the library's is one; a ``compare`` that is only a Command (no
    ``score``) is refused with one line naming the contract, before any store is read."""
    library = registry.commands()["compare"]
    assert isinstance(library, ScoringCommand)
    monkeypatch.setattr(registry, "commands", lambda: {"compare": FINE})
    code, err = pasim(capsys, "score", "nowhere.zarr", "--against", "ref.zarr")
    assert code == 2, err
    assert "need the block library's `compare` command" in err and "ScoringCommand" in err, err
    assert "Traceback" not in err
