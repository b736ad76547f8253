"""A store holds every item xradar's FM-301 model lists (global attributes, root variables,
per-sweep metadata), with true values, and xradar and Py-ART still read it."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
import xradar.model as xm

from ..conftest import GRAPHS, run_cli

UNIFORM = str(GRAPHS / "uniform_staggered.yaml")
GENERIC = str(GRAPHS / "generic_radar.yaml")
FAST = ["--sector", "0:2", "--set", "weather.method=expected"]
#: A staggered PRT needs time series: the fewest pulses the staggered processor takes.
STAGGERED = ["--sector", "0:2", "--set", "scan.pulses=16"]


def _run(tmp_path_factory, graph: str, name: str, args: list[str]) -> xr.DataTree:
    out = tmp_path_factory.mktemp(name) / "store.zarr"
    res = run_cli("run", graph, *args, "--out", str(out))
    assert res.returncode == 0, res.stderr
    return xr.open_datatree(out, engine="zarr")


@pytest.fixture(scope="module")
def staggered(tmp_path_factory) -> xr.DataTree:
    return _run(tmp_path_factory, UNIFORM, "staggered", STAGGERED)


def test_store_holds_every_fm301_item_xradar_lists(staggered):
    root = staggered.to_dataset()
    assert set(xm.required_global_attrs) <= set(root.attrs)
    assert set(xm.required_root_vars) <= set(root.variables)
    sweep = staggered["sweep_0"].to_dataset()
    assert set(xm.required_sweep_metadata_vars) <= set(sweep.variables)


def test_fm301_items_hold_true_values(staggered):
    root = staggered.to_dataset()
    assert root.attrs["instrument_name"] == "uniform_staggered"
    assert root.attrs["platform_is_mobile"] == "false"
    assert "Li et al., 2019" in root.attrs["references"]
    assert "Remote Sensing" in root.attrs["references"]
    assert "PASIM-graph" in root.attrs["institution"]
    assert (
        "pasim run" in root.attrs["history"] and "uniform_staggered.yaml" in root.attrs["history"]
    )
    np.datetime64(root.attrs["history"].split("Z:")[0])  # starts with the UTC time of the run
    assert root.attrs["comment"]
    assert [str(v) for v in root["sweep_group_name"].values] == ["sweep_0"]
    sweep = staggered["sweep_0"].to_dataset()
    np.testing.assert_array_equal(root["sweep_fixed_angle"].values, [sweep["sweep_fixed_angle"]])
    assert str(sweep["prt_mode"].values) == "staggered"
    assert str(sweep["follow_mode"].values) == "none"


def test_a_uniform_prt_scan_is_fixed_and_xradar_and_pyart_read_it(tmp_path_factory):
    import pyart  # noqa: F401  (registers the .pyart accessor)
    import xradar  # noqa: F401  (registers the .xradar accessor)

    tree = _run(tmp_path_factory, GENERIC, "fixed", FAST)
    sweep = tree["sweep_0"].to_dataset()
    assert str(sweep["prt_mode"].values) == "fixed"
    assert tree.attrs["instrument_name"] == "generic_radar"
    assert np.isfinite(tree.xradar.georeference()["sweep_0"].to_dataset()["x"].values).all()
    radar = tree.pyart.to_radar()
    assert "DBZH" in radar.fields
    assert radar.nsweeps == 1
