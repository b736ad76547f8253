"""The layout writer (pasim_graph/store/layout.py ``write_layout``) against xarray's own
``to_zarr(compute=False)``, and the layout staged in memory (``lay_out``) against the one laid
out on disk array by array: the same files, byte for byte, for a real run's sweep."""

from __future__ import annotations

from pathlib import Path

import pytest
import xarray as xr

from pasim_graph.store.format import DONE, encoding, quiet_zarr_warnings
from pasim_graph.store.layout import (
    SweepLayout,
    create_root,
    create_sweep,
    lay_out,
    sweep_template,
    write_layout,
)

from ..conftest import GRAPHS, pasim_in_process


def files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def real_run(tmp_path_factory) -> xr.DataTree:
    """A real run's store, in memory: both tests lay out its sweep (neither changes it)."""
    run = tmp_path_factory.mktemp("real") / "run.zarr"
    args = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "280:283"]
    assert pasim_in_process(*args, "--set", "weather.method=expected", "--out", str(run))[0] == 0
    return xr.open_datatree(run, engine="zarr").load()


def test_the_layout_is_the_one_xarray_writes(tmp_path, real_run):
    sweep = real_run["sweep_0"].to_dataset()
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
    assert len(a) > 40 and any("/c." in name for name in a)  # metadata and in-memory values
    assert sorted(a) == sorted(b)
    assert [n for n in a if a[n] != b[n]] == []


def test_the_staged_layout_is_the_one_laid_out_on_disk(tmp_path, real_run):
    tree = real_run
    sweep = tree["sweep_0"].to_dataset()
    root = tree.to_dataset(inherit=False).drop_vars(DONE)
    coords = {n: sweep[n].variable for n in sweep.coords if "azimuth" in sweep[n].dims}
    first = sweep.isel(azimuth=slice(0, 1))
    sweeps = [SweepLayout(g, first, coords, 3, 2) for g in ("sweep_0", "sweep_1")]
    staged, direct = tmp_path / "staged.zarr", tmp_path / "direct.zarr"
    lay_out(staged, sweeps, root, 4)
    for s in sweeps:
        create_sweep(direct, s.group, s.sweep, s.beam_coords, s.n_beams, s.chunk_beams)
    create_root(direct, root, 4)
    a, b = files(staged), files(direct)
    assert len(a) > 80 and f"{DONE}/zarr.json" in a and "sweep_1/DBZH/zarr.json" in a
    assert sorted(a) == sorted(b)
    assert [n for n in a if a[n] != b[n]] == []
