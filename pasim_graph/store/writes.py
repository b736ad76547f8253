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
    from zarr.core.sync import sync

    beam_dim = beam_dimension(sweep)
    region_vars = [str(n) for n, v in sweep.data_vars.items() if beam_dim in v.dims]
    ds = sweep[region_vars].drop_vars(list(sweep.coords), errors="ignore")
    stop = start + sweep.sizes[beam_dim]
    # What is stored must be what was computed: xarray casts silently (complex to real drops
    # the Q channel), so a variable whose dtype differs from its stored array's is refused.
    stored = sync(_open_arrays(str(path), group, region_vars))
    for name in region_vars:
        kind, dtype = ds[name].dtype.kind, stored[name].dtype
        if kind in "fciub" and dtype != ds[name].dtype:
            raise TypeError(
                f"{path}: variable {name} is {ds[name].dtype} but its store holds {dtype}; "
                "refusing to cast it"
            )
    # Every chunk is written, even one that holds only NaN, so that in a finished store a
    # missing chunk file is damage (check_chunks), never a silent NaN.
    raw = [n for n in region_vars if writes_raw(ds[n], stored[n])]
    writes = [
        (
            stored[name],
            tuple(slice(start, stop) if d == beam_dim else slice(None) for d in ds[name].dims),
            ds[name].values,
        )
        for name in raw
    ]
    if writes:
        sync(_write_arrays(writes))
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


async def _open_arrays(path: str, group: str, names: list[str]) -> dict[str, Any]:
    """The arrays ``names`` of ``group``, opened at once (zarr's asynchronous arrays)."""
    import asyncio

    from zarr.api.asynchronous import open_group

    stored = await open_group(store=path, path=group, mode="r+")
    arrays = await asyncio.gather(*(stored.getitem(name) for name in names))
    return dict(zip(names, arrays, strict=True))


async def _write_arrays(writes: list[tuple[Any, tuple[slice, ...], np.ndarray]]) -> None:
    """Write each (array, region, values) at once: one chunk's arrays in 0.11 s of CPU
    rather than 0.19 one after another (generic radar, 8 beams, 23 arrays). Every write ends,
    or fails, before the first failure is raised: none is left writing behind the caller."""
    import asyncio

    done = await asyncio.gather(
        *(
            array.with_config({"write_empty_chunks": True}).setitem(where, values)
            for array, where, values in writes
        ),
        return_exceptions=True,
    )
    for outcome in done:
        if isinstance(outcome, BaseException):
            raise outcome


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
