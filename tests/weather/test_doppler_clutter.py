"""The ground-clutter block (``clutter.ground``) and the spectral processor in a graph.

What each test compares against:

* power: a uniform clutter map of Z_c seen through the weather channel's calibration gives
  back Z_c (the radar equation: the clutter is weighted by the same two-way pattern the
  radar constant is computed with), within 0.3 dB on 2,000 gates (the clutter's narrow
  spectrum gives about one independent sample per dwell: the mean of 2,000 exponential
  powers has a standard error of 0.1 dB);
* spectrum width: the time series' autocorrelation at lag 32 against the Gaussian spectrum
  of width sqrt(sigma_veg^2 + sigma_scan^2), sigma_scan = alpha lambda sqrt(ln 2) /
  (2 pi theta_1) (Doviak and Zrnic 1993) for the rotating antenna and sigma_veg alone for an
  electronically steered beam, within 10 %;
* the antenna's motion from its pattern: the pencil beam rotates, the planar array does not;
* the graph: GMAP in the spectral processor on the uniform scene under 40 dB of clutter
  scores DBZH and VRADH biases under 1 dB and 1 m/s, with CCORH near 40 dB.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.weather.clutter import GroundClutter, scan_modulation_width

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load

from ..conftest import GRAPHS

WAVELENGTH_M = 299_792_458.0 / 2.8e9
GRAPH = GRAPHS / "uniform_clutter.yaml"


def run(overrides: dict, seed: int = 1, save_iq: bool = False):
    return LocalExecutor(load(GRAPH, overrides), RunOptions(seed=seed, save_iq=save_iq)).run()


def clutter_only(motion: str):
    return run(
        {
            "scene.reflectivity_dbz": -60.0,
            "clutter.clutter_dbz": 60.0,
            "clutter.antenna_motion": motion,
            "spectral.clutter_filter": "none",
            "spectral.window": "rectangular",
        },
        save_iq=True,
    )


def width_at_lag(iq: np.ndarray, lag: int, prt_s: float) -> float:
    r = np.mean(np.conj(iq[..., :-lag]) * iq[..., lag:])
    r0 = np.mean(np.abs(iq) ** 2)
    return float(WAVELENGTH_M / (np.pi * lag * prt_s) * np.sqrt(-np.log(abs(r) / r0) / 8))


@pytest.mark.parametrize("motion", ["rotating", "electronic"])
def test_clutter_power_and_width(motion):
    sweep = clutter_only(motion)
    dbz = 10 * np.log10(np.nanmean(10 ** (sweep["DBZH"].values / 10)))
    assert abs(dbz - 60.0) < 0.3
    veg = GroundClutter.params["vegetation_width_ms"].default
    expected = veg
    if motion == "rotating":
        rate = 1.0 / (64 * 1e-3)  # one 1-deg beam per dwell of 64 pulses of 1 ms
        expected = np.hypot(veg, scan_modulation_width(rate, WAVELENGTH_M, 1.0))
    measured = width_at_lag(sweep["IQ_H"].values, 32, 1e-3)
    assert abs(measured / expected - 1) < 0.1


def test_antenna_motion_from_pattern():
    from pasim_blocks.weather.clutter import ROTATING

    assert "antenna.pencil" in ROTATING
    assert "planar" not in ROTATING and "cylindrical" not in ROTATING


def test_gmap_in_the_graph():
    """Uniform scene (30 dBZ, SNR 30 dB, v 5 m/s, w 2 m/s) under a 70 dBZ clutter map."""
    sweep = run({})
    err_z = sweep["error_DBZH"].values
    err_v = sweep["error_VRADH"].values
    assert abs(np.nanmean(err_z)) < 1.0
    assert abs(np.nanmean(err_v)) < 1.0
    assert 37.0 < np.nanmedian(sweep["CCORH"].values) < 43.0
    unfiltered = run({"spectral.clutter_filter": "none"})
    assert np.nanmean(unfiltered["error_DBZH"].values) > 30.0


def test_file_source_needs_a_path():
    problems = GroundClutter.check_config({"source": "file"}, set())
    assert problems and "path" in problems[0][0]


def test_clutter_map_from_file(tmp_path):
    """A NetCDF map on the truth's grid: 60 dBZ on the first 40 gates, none beyond; the
    estimated clutter reflectivity follows it (within 0.5 dB where present, nothing beyond
    the first gates the range response reaches)."""
    import xarray as xr

    n_radials, gates = 720, 100
    dbz = np.full((n_radials, gates), np.nan)
    dbz[:, :40] = 60.0
    path = tmp_path / "clutter.nc"
    xr.Dataset({"clutter_dbz": (("radial", "gate"), dbz)}).to_netcdf(path)
    sweep = run(
        {
            "scene.reflectivity_dbz": -60.0,
            "clutter.source": "file",
            "clutter.path": str(path),
            "spectral.clutter_filter": "none",
            "spectral.window": "rectangular",
            "scan.azimuth_stop_deg": 6.0,
        }
    )
    z = sweep["DBZH"].values
    inside = 10 * np.log10(np.nanmean(10 ** (z[:, 2:38] / 10)))
    assert abs(inside - 60.0) < 0.5
    assert np.nanmax(z[:, 45:]) < 0.0
