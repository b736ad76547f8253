"""`pasim plot`: truth | estimate | error of each moment as PPIs, on a real small run."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from matplotlib.image import imread
from pasim_blocks.products.moment_figures import (
    STYLES,
    moment_row,
    open_sweep,
    ppi_mesh,
    store_figure,
)

from pasim_graph.store import summarize

from ..conftest import GRAPHS, generic_expected_run, pasim_result

GENERIC = str(GRAPHS / "generic_radar.yaml")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """A 4-beam run of the generic radar at the fastest fidelity level."""
    return generic_expected_run(tmp_path_factory.mktemp("plot") / "run.zarr", "280:284")


def test_plot_draws_a_row_per_moment(store, tmp_path, capsys):
    out = tmp_path / "all.png"
    res = pasim_result(capsys, "plot", str(store), "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert "note:" not in res.stderr  # every moment is in a full run
    img = imread(out)
    one = tmp_path / "one.png"
    assert (
        pasim_result(capsys, "plot", str(store), "--fields", "DBZH", "--out", str(one)).returncode
        == 0
    )
    row = imread(one)
    assert img.shape[1] == row.shape[1]
    # Six rows of panels: the picture is about six times as tall as one row.
    assert 5.0 < img.shape[0] / row.shape[0] < 7.0


def test_panels_use_fixed_limits_and_the_weather_maps(store):
    sweep, _ = open_sweep(store)
    fig = store_figure(sweep, ["DBZH", "VRADH", "RHOHV"], scores=summarize(sweep))
    # The nine panels come first (the colour bars are axes added after them), by row:
    # truth, estimate, error.
    meshes = [ax.collections[0] for ax in fig.axes[:9]]
    dbz_truth, dbz_est, dbz_err, v_truth, v_est, v_err, rho_truth, rho_est, rho_err = meshes
    assert dbz_truth.get_clim() == dbz_est.get_clim() == (-10.0, 70.0)
    assert dbz_truth.get_cmap().name == "ChaseSpectral"
    assert dbz_err.get_clim() == (-5.0, 5.0) and dbz_err.get_cmap().name == "balance"
    nyquist = float(sweep["nyquist_velocity"].max())
    assert v_truth.get_clim() == v_est.get_clim() == pytest.approx((-nyquist, nyquist))
    assert v_est.get_cmap().name == "balance"
    assert v_err.get_clim() == (-5.0, 5.0)
    assert rho_truth.get_clim() == rho_est.get_clim() == (0.7, 1.05)
    lim = STYLES["RHOHV"].error_limit
    assert rho_err.get_clim() == (-lim, lim)
    # The panels hold the store's values, gate for gate (NaN masked).
    np.testing.assert_array_equal(
        np.ma.filled(dbz_est.get_array(), np.nan).reshape(sweep["DBZH"].shape),
        np.asarray(sweep["DBZH"].values, dtype=np.float64),
    )


def test_ppi_geometry_is_km_east_and_north():
    sweep = xr.Dataset(
        {"DBZH": (("azimuth", "range"), np.zeros((2, 2)))},
        coords={
            "azimuth": [89.5, 90.5],
            "range": [10_000.0, 20_000.0],
            "elevation": ("azimuth", [0.0, 0.0]),
        },
    )
    x, y = ppi_mesh(sweep)
    # Corners at 89-91 deg and 5-25 km: due east of the radar.
    assert x.max() == pytest.approx(25.0) and x.min() == pytest.approx(5 * np.cos(np.radians(1)))
    assert abs(y).max() == pytest.approx(25 * np.sin(np.radians(1)))


def test_a_row_without_truth_says_so(store):
    sweep, _ = open_sweep(store)
    sweep = sweep.drop_vars(["truth_DBZH"])
    fig = store_figure(sweep, ["DBZH"])
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert "truth_DBZH\nnot in the store" in texts


def test_missing_fields_are_skipped_with_a_note(tmp_path, capsys):
    out = tmp_path / "dbz.zarr"
    res = pasim_result(capsys,
        "run", GENERIC, "--sector", "280:282", "--set", "weather.method=expected",
        "--outputs", "DBZH", "--out", str(out),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    png = tmp_path / "dbz.png"
    res = pasim_result(capsys, "plot", str(out), "--fields", "DBZH,ZDR,NOPE", "--out", str(png))
    assert res.returncode == 0, res.stderr
    assert "note: ZDR: neither ZDR nor truth_ZDR is in the store; skipped" in res.stderr
    assert "note: NOPE: not a moment this plot knows" in res.stderr
    assert png.exists()
    res = pasim_result(capsys, "plot", str(out), "--fields", "ZDR", "--out", str(png))
    assert res.returncode == 2 and "none of the fields can be drawn" in res.stderr


def test_not_a_store_exits_2_naming_it(tmp_path, capsys):
    res = pasim_result(capsys, "plot", str(tmp_path / "missing.zarr"))
    assert res.returncode == 2
    assert f"{tmp_path / 'missing.zarr'}: no such store" in res.stderr
    res = pasim_result(capsys, "plot", str(GRAPHS))
    assert res.returncode == 2
    assert f"{GRAPHS}: not a PASIM-graph store" in res.stderr
    assert "Traceback" not in res.stderr


def test_scores_are_written_on_the_error_panels(store):
    sweep, _ = open_sweep(store)
    scores = summarize(sweep)
    import matplotlib.figure

    fig = matplotlib.figure.Figure()
    axes = fig.subplots(1, 3)
    moment_row(fig, axes, sweep, "VRADH", scores)
    s = scores["VRADH"]
    (text,) = [t.get_text() for t in axes[2].texts]
    assert f"bias {s['bias']:.3g}" in text
    assert ("pass" if s["pass"] else "fail") in text


def test_the_studio_finds_the_run_pictures_through_the_figures_entry_point(store):
    """The engine draws no moment itself: the block library registers ``run_figures`` in the
    ``pasim_graph.figures`` group, and a PNG comes back for each moment in the store."""
    from pasim_graph import registry

    make = registry.figure_makers()["moments"]
    sweep, _ = open_sweep(store)
    pictures, notes = make(sweep.load(), summarize(sweep), 40)
    assert [name for name, _ in pictures] == list(STYLES) and notes == []
    assert all(png.startswith(b"\x89PNG\r\n\x1a\n") for _, png in pictures)
