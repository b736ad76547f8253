"""Whether a computed variable's values are, byte for byte, what xarray's ``to_zarr`` would
store in a Zarr array: then a chunk is written with zarr directly, without xarray's per-call
cost (about 80 ms a chunk, most of a small run's writing)."""

from __future__ import annotations

import base64
import binascii
from typing import Any

import numpy as np
import xarray as xr


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
