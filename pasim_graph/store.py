"""The run product: a radar volume in the WMO FM-301 / CfRadial 2 layout, written to Zarr.

The root group holds the site and the run's provenance; ``sweep_0`` holds the beams along
``azimuth`` with ``range``, as xradar models a sweep, so ``xarray.open_datatree(store,
engine="zarr")`` opens it and xradar and Py-ART can use it.
"""

from __future__ import annotations

import contextlib
import shutil
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .ports import BEAM_DIM

_SITE = ("latitude", "longitude", "altitude")
_ROOT_VARS = (
    "time_coverage_start",
    "time_coverage_end",
    "volume_number",
    "platform_type",
    "instrument_type",
)


class StoreExistsError(FileExistsError):
    pass


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    with warnings.catch_warnings():
        # Consolidated metadata and fixed-width strings are zarr-python v3 extensions that
        # xarray and xradar read back fine; the warnings only say other readers may not.
        warnings.filterwarnings("ignore", message=".*Consolidated metadata.*")
        warnings.filterwarnings("ignore", message=".*does not have a Zarr V3 specification.*")
        yield


def split_volume(sweep: xr.Dataset, attrs: dict[str, Any]) -> tuple[xr.Dataset, xr.Dataset]:
    """Name the beam dimension, and move site and volume metadata to a root dataset."""
    if BEAM_DIM in sweep.dims:
        beam_dim = str(sweep.attrs.pop("beam_dimension", "azimuth"))
        sweep = sweep.swap_dims({BEAM_DIM: beam_dim})
    root = xr.Dataset(attrs=dict(attrs))
    for name in _SITE:
        if name in sweep.variables:
            root = root.assign_coords({name: sweep[name].variable})
    for name in _ROOT_VARS:
        if name in sweep.variables:
            root[name] = sweep[name].variable
            sweep = sweep.drop_vars(name)
    return root, sweep


def write_volume(
    path: str | Path, sweep: xr.Dataset, attrs: dict[str, Any], overwrite: bool = False
) -> None:
    """Write one whole sweep and the root group to a Zarr store (``attrs`` go on the root)."""
    path = Path(path)
    if path.exists():
        if not overwrite:
            raise StoreExistsError(f"{path} exists; pass --overwrite to replace it")
        shutil.rmtree(path)
    root, sweep = split_volume(sweep, attrs)
    tree = xr.DataTree.from_dict({"/": root, "/sweep_0": sweep})
    with _quiet():
        tree.to_zarr(path, mode="w", consolidated=True)


# Incremental writing: a template first, then each chunk's region as it finishes, a done flag
# per chunk, and the completion marker last, so that a killed run can be resumed and a store
# never looks complete when it is not.
DONE = "pasim_chunk_done"
COMPLETE = "pasim_complete"


def create_volume(
    path: str | Path,
    root: xr.Dataset,
    sweep: xr.Dataset,
    beam_coords: dict[str, xr.Variable],
    n_beams: int,
    chunk_beams: int,
    n_chunks: int,
) -> None:
    """Write the store's metadata and every array that does not depend on the chunks.

    ``sweep`` holds one chunk's data; its beam-dimension variables are laid out at full size
    (``n_beams``), chunked by ``chunk_beams`` so that chunks write disjoint Zarr chunks.
    ``beam_coords`` are the coordinates along the beams for every beam.
    """
    import dask.array as da

    beam_dim = beam_dimension(sweep)
    template = {}
    for name, var in sweep.data_vars.items():
        if beam_dim in var.dims:
            shape = tuple(n_beams if d == beam_dim else sweep.sizes[d] for d in var.dims)
            chunks = tuple(chunk_beams if d == beam_dim else sweep.sizes[d] for d in var.dims)
            template[name] = xr.Variable(
                var.dims, da.zeros(shape, var.dtype, chunks=chunks), var.attrs
            )
            if np.issubdtype(var.dtype, np.floating) or np.issubdtype(
                var.dtype, np.complexfloating
            ):
                template[name].encoding["fill_value"] = np.nan
        else:
            template[name] = var.variable
    coords = {n: c.variable for n, c in sweep.coords.items() if beam_dim not in c.dims}
    ds = xr.Dataset(template, coords={**coords, **beam_coords}, attrs=sweep.attrs)
    done = xr.Dataset({DONE: ("pasim_chunk", np.zeros(n_chunks, np.int8))})
    root = root.assign(done)
    root.attrs[COMPLETE] = "false"
    with _quiet():
        root.to_zarr(path, mode="w", consolidated=False, encoding={DONE: {"chunks": (1,)}})
        ds.to_zarr(path, group="sweep_0", mode="a", consolidated=False, compute=False)


def write_region(path: str | Path, sweep: xr.Dataset, start: int, chunk_index: int) -> None:
    """Write one chunk's beams into their region, then flag the chunk as done."""
    beam_dim = beam_dimension(sweep)
    region_vars = [n for n, v in sweep.data_vars.items() if beam_dim in v.dims]
    ds = sweep[region_vars].drop_vars(list(sweep.coords), errors="ignore")
    stop = start + sweep.sizes[beam_dim]
    with _quiet():
        ds.to_zarr(path, group="sweep_0", region={beam_dim: slice(start, stop)}, consolidated=False)
        flag = xr.Dataset({DONE: ("pasim_chunk", np.ones(1, np.int8))})
        flag.to_zarr(
            path, region={"pasim_chunk": slice(chunk_index, chunk_index + 1)}, consolidated=False
        )


def run_state(path: str | Path) -> tuple[dict[str, Any], np.ndarray] | None:
    """Root attributes and per-chunk done flags of a store, or ``None`` if it has no run."""
    import zarr

    try:
        root = zarr.open_group(str(path), mode="r")
        done = np.asarray(root[DONE][...])  # type: ignore[index]
    except Exception:  # not a store, or a template that never finished being written
        return None
    return dict(root.attrs), done


def mark_complete(path: str | Path) -> None:
    """The last write of a run: flag the store complete and consolidate its metadata."""
    import zarr

    root = zarr.open_group(str(path), mode="r+")
    root.attrs[COMPLETE] = "true"
    with _quiet():
        zarr.consolidate_metadata(str(path))


def beam_dimension(sweep: xr.Dataset) -> str:
    """The dimension a stored sweep's beams run along."""
    for name in ("azimuth", "elevation", "time"):
        if name in sweep.dims:
            return name
    raise ValueError("a sweep needs an azimuth, elevation or time dimension")


class IncompleteStoreError(RuntimeError):
    pass


def open_volume(path: str | Path) -> xr.DataTree:
    """Open a finished run's volume (refuses a run that was interrupted)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
    state = run_state(path)
    if state is not None and state[0].get(COMPLETE) != "true":
        done = int(state[1].sum())
        raise IncompleteStoreError(
            f"{path}: the run did not finish ({done} of {state[1].size} chunks written); "
            "complete it with `pasim run ... --resume`"
        )
    with _quiet():
        return xr.open_datatree(path, engine="zarr")


def summarize(sweep: xr.Dataset) -> dict[str, dict[str, Any]]:
    """Bias and standard deviation of every error field a scorer wrote into the sweep.

    Error fields carry ``pasim_role = "error"`` and the requirement they are judged against;
    a field with ``pasim_role = "scored"`` marks the gates that met the scoring rule, so that
    scored gates without an estimate (undefined, e.g. noise-corrected power <= 0) are counted.
    """
    scored_vars = [v for v in sweep.data_vars.values() if v.attrs.get("pasim_role") == "scored"]
    n_scored = int(np.asarray(scored_vars[0].values).sum()) if scored_vars else None
    out: dict[str, dict[str, Any]] = {}
    for name, var in sweep.data_vars.items():
        if var.attrs.get("pasim_role") != "error":
            continue
        values = np.asarray(var.values, dtype=np.float64)
        finite = np.isfinite(values)
        n = int(finite.sum())
        # Scored gates whose truth has this moment but whose estimate is undefined.
        unestimated = 0
        truth_name = var.attrs.get("truth_variable")
        if scored_vars and truth_name in sweep:
            has_truth = np.isfinite(np.asarray(sweep[truth_name].values))
            unestimated = int(
                (np.asarray(scored_vars[0].values).astype(bool) & has_truth & ~finite).sum()
            )
        values = values[finite]
        bias = float(values.mean()) if n else float("nan")
        std = float(values.std(ddof=1)) if n > 1 else float("nan")
        req_b = float(var.attrs["requirement_bias"])
        req_s = float(var.attrs["requirement_std"])
        out[str(var.attrs.get("moment", name))] = {
            "bias": bias,
            "std": std,
            "count": n,
            "units": var.attrs.get("units", ""),
            "requirement_bias": req_b,
            "requirement_std": req_s,
            "pass": bool(n > 1 and abs(bias) <= req_b and std <= req_s),
            "scored_gates": n_scored if n_scored is not None else n,
            "unestimated": unestimated,
            "scored": var.attrs.get("scored", ""),
        }
    return out
