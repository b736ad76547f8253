"""A chunk's region is written with zarr directly where its values are its stored bytes, and
through xarray's ``to_zarr`` otherwise (CF-encoded times): both read back through xarray as
what was computed, every chunk file exists (even an all-NaN one), and the chunk is flagged.

The independent reference is xarray itself: the same chunks written by ``Dataset.to_zarr``
with a region into a second store laid out the same way.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from pasim_graph.store import create_volume, run_state, write_region

BEAMS, GATES, CHUNK = 6, 5, 3


def chunk(start: int) -> xr.Dataset:
    az = np.arange(start, start + CHUNK, dtype=np.float64)
    rng = np.random.default_rng(start)
    dbz = rng.normal(20, 5, (CHUNK, GATES)).astype(np.float32)
    if start:
        dbz[:] = np.nan  # a chunk of no data is still written (check_chunks)
    iq = (rng.normal(size=(CHUNK, GATES)) + 1j * rng.normal(size=(CHUNK, GATES))).astype(
        np.complex64
    )
    when = np.datetime64("2016-06-01T15:00:25", "ns") + (az * 1e9).astype("timedelta64[ns]")
    return xr.Dataset(
        {
            "DBZH": (("azimuth", "range"), dbz, {"units": "dBZ"}),
            "iq": (("azimuth", "range"), iq),
            "scored": (("azimuth", "range"), (dbz > 20).astype(np.int8)),
            "beam_time": (("azimuth",), when),
            "site": ((), np.float64(1.5)),
        },
        coords={"azimuth": az, "range": np.arange(GATES) * 250.0},
    )


def lay_out(path) -> None:
    first = chunk(0)
    coords = {"azimuth": xr.Variable("azimuth", np.arange(BEAMS, dtype=np.float64))}
    create_volume(path, xr.Dataset(attrs={"title": "t"}), first, coords, BEAMS, CHUNK, 2)


def test_direct_and_xarray_writes_read_back_as_computed(tmp_path):
    ours, theirs = tmp_path / "ours.zarr", tmp_path / "theirs.zarr"
    lay_out(ours)
    lay_out(theirs)
    for index, start in enumerate((0, CHUNK)):
        ds = chunk(start)
        write_region(ours, ds, start, index)
        region = ds.drop_vars(["azimuth", "range", "site"])
        region.to_zarr(theirs, group="sweep_0", region={"azimuth": slice(start, start + CHUNK)})
    a = xr.open_datatree(ours, engine="zarr")["sweep_0"].to_dataset()
    b = xr.open_datatree(theirs, engine="zarr")["sweep_0"].to_dataset()
    for name in ("DBZH", "iq", "scored", "beam_time"):
        assert a[name].dtype == b[name].dtype, name
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    assert np.isnan(a["DBZH"].values[CHUNK:]).all()
    assert np.iscomplexobj(a["iq"].values) and np.abs(a["iq"].values.imag).sum() > 0
    assert a["beam_time"].values[1] == np.datetime64("2016-06-01T15:00:26", "ns")
    for name in ("DBZH", "iq", "scored", "beam_time"):
        files = sorted(p.name for p in (ours / "sweep_0" / name / "c").rglob("*") if p.is_file())
        assert len(files) == 2, (name, files)
    state = run_state(ours)
    assert state is not None and state[1].tolist() == [1, 1]
