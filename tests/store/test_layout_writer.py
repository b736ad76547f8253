"""The layout writer (pasim_graph/store/layout.py ``write_layout``) against xarray's own
``to_zarr(compute=False)``: the same files, byte for byte, for a real run's sweep."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from pasim_graph.store.format import encoding, quiet_zarr_warnings
from pasim_graph.store.layout import sweep_template, write_layout

from ..conftest import GRAPHS, pasim_in_process


def files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_the_layout_is_the_one_xarray_writes(tmp_path):
    run = tmp_path / "run.zarr"
    args = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "280:283"]
    assert pasim_in_process(*args, "--set", "weather.method=expected", "--out", str(run))[0] == 0
    sweep = xr.open_datatree(run, engine="zarr")["sweep_0"].to_dataset().load()
    coords = {n: sweep[n].variable for n in sweep.coords if "azimuth" in sweep[n].dims}
    first = sweep.isel(azimuth=slice(0, 1))
    template = sweep_template(first, coords, 3, 2)
    enc = {n: encoding(v.dtype) for n, v in template.variables.items()}
    ours, theirs = tmp_path / "ours.zarr", tmp_path / "theirs.zarr"
    with quiet_zarr_warnings():
        write_layout(template, ours, "sweep_0", enc)
        template.to_zarr(
            theirs,
            group="sweep_0",
            mode="a",
            consolidated=False,
            compute=False,
            encoding=enc,
            write_empty_chunks=True,
        )
    a, b = files(ours), files(theirs)
    assert len(a) > 40 and any("/c/" in name for name in a)  # metadata and in-memory values
    assert sorted(a) == sorted(b)
    assert [n for n in a if a[n] != b[n]] == []
