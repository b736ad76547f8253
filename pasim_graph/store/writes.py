"""Writing a chunk into its region of a laid-out store, then flagging it done.

Plain numbers are written with zarr directly when their values are, byte for byte, what
xarray's ``to_zarr`` would store (:func:`writes_raw`): that saves xarray's per-call cost
(about 80 ms a chunk, most of a small run's writing); anything else goes through xarray.
"""

from __future__ import annotations

import base64
import binascii
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .format import DONE, beam_dimension, quiet_zarr_warnings


def write_region(
    path: str | Path, sweep: xr.Dataset, start: int, chunk_index: int, group: str = "sweep_0"
) -> None:
    """Write one chunk's beams into their region of ``group``, then flag the chunk (its
    index among all the run's chunks) as done."""
    import zarr

    beam_dim = beam_dimension(sweep)
    region_vars = [n for n, v in sweep.data_vars.items() if beam_dim in v.dims]
    ds = sweep[region_vars].drop_vars(list(sweep.coords), errors="ignore")
    stop = start + sweep.sizes[beam_dim]
    # What is stored must be what was computed: xarray casts silently (complex to real drops
    # the Q channel), so a variable whose dtype differs from its stored array's is refused.
    stored_group = zarr.open_group(str(path), path=group, mode="r+")
    stored = {str(name): stored_group[str(name)] for name in region_vars}
    for name in region_vars:
        kind, dtype = ds[name].dtype.kind, stored[str(name)].dtype  # type: ignore[union-attr]
        if kind in "fciub" and dtype != ds[name].dtype:
            raise TypeError(
                f"{path}: variable {name} is {ds[name].dtype} but its store holds {dtype}; "
                "refusing to cast it"
            )
    # Every chunk is written, even one that holds only NaN, so that in a finished store a
    # missing chunk file is damage (check_chunks), never a silent NaN.
    raw = [n for n in region_vars if writes_raw(ds[n], stored[str(n)])]
    for name in raw:
        array = stored[str(name)].with_config({"write_empty_chunks": True})  # type: ignore[union-attr]
        where = tuple(slice(start, stop) if d == beam_dim else slice(None) for d in ds[name].dims)
        array[where] = ds[name].values
    rest = [n for n in region_vars if n not in raw]
    with quiet_zarr_warnings():
        if rest:
            ds[rest].to_zarr(
                path,
                group=group,
                region={beam_dim: slice(start, stop)},
                consolidated=False,
                write_empty_chunks=True,
            )
        flags = zarr.open_array(str(path), path=DONE, mode="r+")
        flags.with_config({"write_empty_chunks": True})[chunk_index] = 1


def writes_raw(variable: xr.DataArray, stored: Any) -> bool:
    """True for plain numbers stored (in the Zarr array ``stored``) with the same dtype and
    dimensions and no CF encoding (times, scale and offset, a fill value other than NaN);
    anything else must go through xarray."""
    if variable.dtype.kind not in "fciu" or stored.dtype != variable.dtype:
        return False
    names = getattr(stored.metadata, "dimension_names", None)
    if names is None or tuple(names) != tuple(variable.dims):
        return False
    attrs = {**stored.attrs, **variable.attrs, **variable.encoding}
    if any(k in attrs for k in ("scale_factor", "add_offset", "calendar")):
        return False
    if (
        " since " in str(attrs.get("units", ""))
        or attrs.get("dtype", variable.dtype) != variable.dtype
    ):
        return False
    fill = attrs.get("_FillValue")
    if fill is None:
        return True  # no CF fill: xarray writes the values as they are
    return variable.dtype.kind in "fc" and is_nan_fill(fill)


def is_nan_fill(fill: Any) -> bool:
    """A CF fill value that is NaN, as a number or as xarray keeps a float fill in a Zarr v3
    attribute (base64 of its little-endian float64 bytes)."""
    if isinstance(fill, str):
        try:
            raw = base64.b64decode(fill, validate=True)
        except (binascii.Error, ValueError):
            return False
        return len(raw) == 8 and bool(np.isnan(np.frombuffer(raw, "<f8")[0]))
    try:
        return bool(np.all(np.isnan(np.asarray(fill, dtype=complex))))
    except (TypeError, ValueError):
        return False
