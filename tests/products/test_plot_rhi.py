"""RHIs end to end: `scan.rhi` with the azimuth constant runs in chunks, is stored along
elevation, and `pasim plot` draws it as range against 4/3-earth height (checked against the
formula and an independent series expansion)."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.image import imread
from pasim_blocks.products.moment_figures import is_rhi, open_sweep, rhi_mesh, store_figure
from pasim_blocks.scans.beam_geometry import EARTH_RADIUS_M, beam_height_m, ground_range_m

from ..conftest import GRAPHS, pasim_out

RHI = str(GRAPHS / "generic_rhi.yaml")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """Six beams, 0.5 to 3 deg, in chunks of 4 (the azimuth is the same in every chunk)."""
    from pasim_graph.cli import main

    out = tmp_path_factory.mktemp("rhi") / "run.zarr"
    args = ["run", RHI, "--set", "scan.elevation_stop_deg=3", "--set", "weather.method=expected"]
    assert main([*args, "--chunk", "4", "--out", str(out)]) == 0
    return out


def test_beam_height_follows_the_four_thirds_earth_model():
    """h = r sin(el) + r^2 / (2 k a) to second order (Doviak and Zrnic 1993, eq. 2.28b
    expanded): within 10 m of the exact form at 100 km and 1 deg; the ground range is
    within 0.1 % of r cos(el) there."""
    r, el = 100e3, 1.0
    ka = 4.0 / 3.0 * EARTH_RADIUS_M
    series = r * np.sin(np.radians(el)) + r**2 / (2 * ka)
    assert abs(float(beam_height_m(r, el)) - series) < 10.0
    assert float(ground_range_m(r, el)) == pytest.approx(r * np.cos(np.radians(el)), rel=1e-3)


def test_rhi_is_stored_along_elevation_at_one_azimuth(store):
    sweep, _ = open_sweep(store)
    assert is_rhi(sweep) and sweep.sizes["elevation"] == 6
    np.testing.assert_allclose(sweep["elevation"].values, [0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    assert np.unique(sweep["azimuth"].values).size == 1
    assert np.isfinite(sweep["DBZH"].values).any()


def test_rhi_mesh_puts_the_gates_at_their_beam_heights(store):
    sweep, _ = open_sweep(store)
    x, y = rhi_mesh(sweep)
    # Mean of a cell's corners ~ the gate centre; compare with the formula at the centre.
    yc = (y[:-1, :-1] + y[1:, :-1] + y[:-1, 1:] + y[1:, 1:]) / 4
    e, r = np.meshgrid(sweep["elevation"].values, sweep["range"].values, indexing="ij")
    np.testing.assert_allclose(yc * 1000, beam_height_m(r, e), atol=5.0)
    assert x.min() >= -1.0 and x.max() * 1000 <= float(sweep["range"].max()) + 500


def test_plot_draws_an_rhi_as_range_height(store, tmp_path, capsys):
    sweep, _ = open_sweep(store)
    fig = store_figure(sweep, ["DBZH"])
    assert "above the radar" in fig.axes[0].get_ylabel()
    assert fig.axes[0].get_xlabel() == "km along the ground"
    out = tmp_path / "rhi.png"
    code, _, err = pasim_out(capsys, "plot", str(store), "--fields", "DBZH", "--out", str(out))
    assert code == 0, err
    assert imread(out).shape[0] > 100
    code, _, err = pasim_out(capsys, "plot", str(store), "--sweep", "3", "--out", str(out))
    assert code == 2 and "no sweep 3" in err and "sweep_0" in err


# Two RHI runs over a volume truth (20 s): -m slow. The default suite checks the same draws
# against the chunking on a volume truth (tests/truth/test_volume_truth.py) and on PPI and
# volume scans (tests/execution/test_dask_executor.py, tests/store/test_volume_store.py).
@pytest.mark.slow
def test_an_rhi_gives_the_same_numbers_whatever_the_chunking(tmp_path):
    """Beams at one azimuth, drawn by the default (random) level: chunks of 1 and of 3 store
    the same values (the volume truth and the physical width model, whose scan modulation is
    each beam's own)."""
    import xarray as xr

    from pasim_graph.cli import main

    args = ["run", RHI, "--set", "scan.elevation_stop_deg=2", "--outputs", "DBZH,ZDR"]
    for chunk in ("1", "3"):
        assert main([*args, "--chunk", chunk, "--out", str(tmp_path / chunk)]) == 0
    a, b = (xr.open_datatree(tmp_path / c, engine="zarr")["sweep_0"] for c in ("1", "3"))
    for name in ("DBZH", "ZDR", "error_DBZH"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    assert np.isfinite(a["DBZH"].values).any()
