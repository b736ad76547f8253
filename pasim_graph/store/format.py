"""What makes a directory a store, and the state of its run: the marker this program writes
first, how every array is encoded, the per-chunk done flags and the completion attribute a run
writes last, and the dimension a stored sweep's beams run along."""

from __future__ import annotations

import contextlib
import json
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..duck_arrays import defer_pint_lookup
from ..fm301 import BEAM_DIMENSIONS
from .lock import LOCK

# Reading a store (plot, score, study, studio) never imports pint for xarray's sake.
defer_pint_lookup()

# A store is a directory this program made: it holds MARKER, written before anything else, and
# while a run writes it, LOCK (whose owner holds an flock on it). Nothing is ever deleted from
# a directory without the marker, and zarr's mode "w" (which empties the whole directory) is
# never used.
MARKER = "pasim-store.json"
_MARKER_FORMAT = "pasim-store/1"


def is_store(path: str | Path) -> bool:
    """True when ``path`` is a directory this program wrote (it carries the marker)."""
    try:
        return json.loads((Path(path) / MARKER).read_text()).get("format") == _MARKER_FORMAT
    except (OSError, ValueError, AttributeError):
        return False


def _marker_text() -> str:
    from .. import __version__

    return json.dumps({"format": _MARKER_FORMAT, "writer": f"pasim-graph {__version__}"}) + "\n"


def write_marker(path: Path) -> None:
    """Mark ``path`` as a store of this program's (the first file written into it)."""
    (path / MARKER).write_text(_marker_text())


def marker_cut_short(path: str | Path) -> bool:
    """True when ``path``'s marker is the start of the one :func:`write_marker` writes, left
    unfinished (a run stopped while marking its new store); not a marker of anyone else's."""
    try:
        text = (Path(path) / MARKER).read_text()
    except (OSError, ValueError):
        return False
    return text != _marker_text() and _marker_text().startswith(text)


# Consolidated metadata and fixed-width strings are zarr-python v3 extensions that xarray and
# xradar read back fine; the warnings only say other readers may not. The store's marker and
# lock files sit beside the Zarr hierarchy on purpose.
_NOISE = (
    ".*Consolidated metadata.*",
    ".*does not have a Zarr V3 specification.*",
    f"Object at ({MARKER}|{LOCK}) is not recognized as a component",
)


@contextlib.contextmanager
def quiet_zarr_warnings() -> Iterator[None]:
    # Filters are added for good, not inside warnings.catch_warnings(): that swaps the
    # process-wide filter list in and out, so chunks writing from several threads at once
    # restored each other's lists and the warnings leaked (seen in one run of three).
    # Adding an identical filter again only moves it to the front.
    for message in _NOISE:
        warnings.filterwarnings("ignore", message=message)
    yield


# Incremental writing: a template first, then each chunk's region as it finishes, a done flag
# per chunk, and the completion marker last, so that a killed run can be resumed and a store
# never looks complete when it is not.
DONE = "pasim_chunk_done"
COMPLETE = "pasim_complete"


def encoding(dtype: np.dtype) -> dict[str, Any]:
    """How every array of a store is written: its own dtype, NaN where nothing was written
    yet (floats and complex), and each chunk zstd-compressed under a CRC-32C checksum, so a
    chunk damaged on disk is an error when read, never a wrong value. Each chunk is a file
    beside its array's metadata (``c.1.0``: zarr's chunk keys with "." for "/"), not a folder
    a chunk: a chunk task made 23 folders besides its 24 files, and where creating an entry
    is dear (a busy disk, a parallel file system's metadata server) the folders cost as much
    as the files (docs/scaling.md). Stores with a folder a chunk read and resume as before.

    The dtype is given explicitly, as a guard: a template built with ``da.zeros(shape, dtype)``
    (dask ignores a positional dtype) was float64 and stored the I/Q cubes without their Q
    channel.
    """
    from zarr.codecs import Crc32cCodec, ZstdCodec

    out: dict[str, Any] = {
        "compressors": [ZstdCodec(level=0), Crc32cCodec()],
        "chunk_key_encoding": {"name": "default", "separator": "."},
    }
    dtype = np.dtype(dtype)
    if dtype.kind in "fc":
        out["dtype"] = dtype
        out["fill_value"] = complex(np.nan, np.nan) if dtype.kind == "c" else np.nan
    elif dtype.kind in "iub":
        out["dtype"] = dtype
    return out


def run_state(path: str | Path) -> tuple[dict[str, Any], np.ndarray] | None:
    """Root attributes and per-chunk done flags of a store, or ``None`` if it has no run."""
    import zarr

    try:
        root = zarr.open_group(str(path), mode="r")
        flags = root[DONE]
    except Exception:  # not a store, or a template that never finished being written
        return None
    done = np.zeros(flags.shape, np.int8)  # type: ignore[union-attr]
    for i in range(done.size):
        # A flag damaged on disk counts as not done: its chunk is simply run again.
        with contextlib.suppress(Exception):
            done[i] = flags[i]  # type: ignore[index]
    return dict(root.attrs), done


def mark_incomplete(path: str | Path) -> None:
    """Flag a store as being written again (its damaged chunks are rewritten)."""
    import zarr

    with quiet_zarr_warnings():
        zarr.open_group(str(path), mode="r+").attrs[COMPLETE] = "false"


def mark_complete(path: str | Path) -> None:
    """The last write of a run: consolidate the store's metadata, then flag it complete.

    In that order, so that a disk that fills during the final write leaves a store that says
    it is incomplete (``--resume`` finishes it), never one marked complete without its
    consolidated metadata. Zarr writes each metadata file atomically.
    """
    import zarr

    with quiet_zarr_warnings():
        zarr.consolidate_metadata(str(path))
        root = zarr.open_group(str(path), mode="r+")
        root.attrs[COMPLETE] = "true"


def beam_dimension(sweep: xr.Dataset) -> str:
    """The dimension a stored sweep's beams run along."""
    for name in BEAM_DIMENSIONS:
        if name in sweep.dims:
            return name
    raise ValueError("a sweep needs an azimuth, elevation or time dimension")
