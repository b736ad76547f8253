"""The run product: a radar volume in the WMO FM-301 / CfRadial 2 layout, written to Zarr.

The root group holds the site and the run's provenance; ``sweep_0`` holds the beams along
``azimuth`` with ``range``, as xradar models a sweep, so ``xarray.open_datatree(store,
engine="zarr")`` opens it and xradar and Py-ART can use it.
"""

from __future__ import annotations

import shutil
import warnings
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


def write_volume(
    path: str | Path, sweep: xr.Dataset, attrs: dict[str, Any], overwrite: bool = False
) -> None:
    """Write one sweep and the root group to a Zarr store (``attrs`` go on the root)."""
    path = Path(path)
    if path.exists():
        if not overwrite:
            raise StoreExistsError(f"{path} exists; pass --overwrite to replace it")
        shutil.rmtree(path)
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
    tree = xr.DataTree.from_dict({"/": root, "/sweep_0": sweep})
    with warnings.catch_warnings():
        # Consolidated metadata and fixed-width strings are zarr-python v3 extensions that
        # xarray and xradar read back fine; the warnings only say other readers may not.
        warnings.filterwarnings("ignore", message=".*Consolidated metadata.*")
        warnings.filterwarnings("ignore", message=".*does not have a Zarr V3 specification.*")
        tree.to_zarr(path, mode="w", consolidated=True)


def open_volume(path: str | Path) -> xr.DataTree:
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
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
