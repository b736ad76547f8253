"""Writing a chunk into its region of a laid-out store, then flagging it done.

Plain numbers are written with zarr directly when their values are, byte for byte, what
xarray's ``to_zarr`` would store (:func:`writes_raw`): that saves xarray's per-call cost
(about 80 ms a chunk, most of a small run's writing); anything else goes through xarray.

A region of whole chunks (every chunk task's) is encoded here, in the calling thread, by the
array's own codecs (:func:`write_arrays`), and its chunk files are written here too where the
store is a local folder (:func:`put_files`: zarr's LocalStore, its atomic write), else handed
to the array's store at once. zarr's asynchronous path costs CPU in its event loop and thread
pool for every tiny file: writing the generic radar's 45 chunks of 23 arrays took 0.49 s of
CPU through it, 0.25 s this way (2026-11-29), on machines whose every core computes chunks. The
chunk files are the same bytes (``tests/store/test_store_writes.py``). A run's arrays are
opened once per process (``run``): opening them read and parsed 24 metadata files a chunk
(0.3 s of the 45). The encoding leans on zarr's codecs' synchronous ``_encode_sync``
(zarr-python 3.0-3.1; not a public API): a codec without it leaves the region to zarr, and the
test holds the bytes to zarr's own.
"""

from __future__ import annotations

import base64
import binascii
import contextlib
import itertools
import os
import threading
import uuid
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor, wait
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .format import DONE, beam_dimension, quiet_zarr_warnings


def write_region(
    path: str | Path,
    sweep: xr.Dataset,
    start: int,
    chunk_index: int,
    group: str = "sweep_0",
    run: str | None = None,
) -> None:
    """Write one chunk's beams into their region of ``group``, then flag the chunk (its
    index among all the run's chunks) as done.

    ``run`` names one run of the store's current layout (a token fresh for every run): its
    arrays are then opened once per process and kept for the run's further chunks. Without
    it they are opened for this call only. A token is never used across a new layout (an
    overwritten store), whose arrays may differ.
    """

    beam_dim = beam_dimension(sweep)
    region_vars = [str(n) for n, v in sweep.data_vars.items() if beam_dim in v.dims]
    ds = sweep[region_vars].drop_vars(list(sweep.coords), errors="ignore")
    stop = start + sweep.sizes[beam_dim]
    # What is stored must be what was computed: xarray casts silently (complex to real drops
    # the Q channel), so a variable whose dtype differs from its stored array's is refused.
    stored = _opened(str(path), group, region_vars, run)
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
        write_arrays(writes)
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
    # Last, once the chunk's values are stored: a flagged chunk is a written one.
    flags = _opened(str(path), "", [DONE], run)[DONE]
    where = (slice(chunk_index, chunk_index + 1),)
    write_arrays([(flags, where, np.ones(1, flags.dtype))])


#: The arrays opened for each (store, group, run), most recent last; a few runs at once
#: (a study's) each keep theirs.
_OPENED: OrderedDict[tuple[str, str, str], dict[str, Any]] = OrderedDict()
_OPENED_RUNS = 16
_OPENED_LOCK = threading.Lock()


def _opened(path: str, group: str, names: list[str], run: str | None) -> dict[str, Any]:
    """The arrays ``names`` of ``group``, opened for this call or (``run``) once per run."""
    from zarr.core.sync import sync

    if run is None:
        return sync(_open_arrays(path, group, names))
    key = (path, group, run)
    with _OPENED_LOCK:
        arrays = _OPENED.get(key, {})
        if key in _OPENED:
            _OPENED.move_to_end(key)
    missing = [n for n in names if n not in arrays]
    if missing:
        arrays = {**arrays, **sync(_open_arrays(path, group, missing))}
        with _OPENED_LOCK:
            _OPENED[key] = arrays
            while len(_OPENED) > _OPENED_RUNS:
                _OPENED.popitem(last=False)
    return {n: arrays[n] for n in names}


async def _open_arrays(path: str, group: str, names: list[str]) -> dict[str, Any]:
    """The arrays ``names`` of ``group`` (the root for ""), opened at once (zarr's
    asynchronous arrays)."""
    import asyncio

    from zarr.api.asynchronous import open_group

    stored = await open_group(store=path, path=group or None, mode="r+")
    arrays = await asyncio.gather(*(stored.getitem(name) for name in names))
    return dict(zip(names, arrays, strict=True))


def write_arrays(writes: list[tuple[Any, tuple[slice, ...], np.ndarray]]) -> None:
    """Write each (array, region, values) at once: regions of whole chunks encoded in the
    calling thread (:func:`_whole_chunks`: the threads of a threaded run encode side by side,
    not one after another in zarr's event loop) and their chunk files stored together, any
    other region through zarr's ``setitem``. Every write ends, or fails, before the first
    failure is raised: none is left writing behind the caller."""
    from zarr.core.sync import sync

    encoded = [(w, _whole_chunks(*w)) for w in writes]
    files = [
        (_local_root(array), chunks) for (array, _, _), chunks in encoded if chunks is not None
    ]
    if len(files) == len(encoded) and all(root for root, _ in files):
        put_files(
            [
                (os.path.join(str(root), key), chunk.as_buffer_like())
                for root, chunks in files
                for key, chunk in chunks
            ]
        )
        return
    sync(_store(encoded))


#: The threads that write half of each call's files (made on first use, in this process).
_HELPERS: dict[int, ThreadPoolExecutor] = {}
_HELPERS_LOCK = threading.Lock()


def put_files(files: list[tuple[str, Any]]) -> None:
    """Write (path, bytes) files: half in the calling thread, half by a helper thread at the
    same time. A file costs little CPU but the kernel's time to create it varies (0.03-1 ms on
    this project's test machine, docs/scaling.md): where a core is free (one worker on two
    cores) the helper takes half of it; where every core computes it costs one hand-over a
    call. All are written, or have failed, before this returns; the first failure is raised."""
    if len(files) < 2:
        _put_all(files)
        return
    half = len(files) // 2
    with _HELPERS_LOCK:
        pool = _HELPERS.get(os.getpid())  # a forked child makes its own
        if pool is None:
            pool = _HELPERS[os.getpid()] = ThreadPoolExecutor(2, "pasim-writes")
    theirs = pool.submit(_put_all, files[:half])
    try:
        _put_all(files[half:])
    except BaseException:
        wait([theirs])  # none left writing behind the caller
        raise
    theirs.result()


def _put_all(files: list[tuple[str, Any]]) -> None:
    for file in files:
        put_file(*file)


def _local_root(array: Any) -> str | None:
    """The folder of ``array``'s store where it is a plain local one (zarr's LocalStore),
    else None."""
    from zarr.storage import LocalStore

    store = array.store_path.store
    return str(store.root) if type(store) is LocalStore else None


def put_file(path: str, data: Any) -> None:
    """Write one chunk file as zarr's LocalStore does: into a fresh ``.partial`` file beside
    it, then renamed over it (a reader sees the old bytes or the new, never part; a failed
    write leaves no partial file). Its folder is made when missing."""
    partial = f"{path}.{uuid.uuid4().hex}.partial"
    try:
        f = open(partial, "wb")  # closed below, before the rename
    except FileNotFoundError:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        f = open(partial, "wb")
    try:
        with f:
            f.write(data)
        os.replace(partial, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(partial)
        raise


async def _store(encoded: list[tuple[tuple[Any, tuple[slice, ...], np.ndarray], Any]]) -> None:
    """Store each write's encoded chunks (or, None, its region through zarr) at once: one
    chunk's 23 arrays in 0.11 s of CPU rather than 0.19 one after another."""
    import asyncio

    puts = []
    for (array, where, values), chunks in encoded:
        if chunks is None:
            puts.append(array.with_config({"write_empty_chunks": True}).setitem(where, values))
        else:
            puts += [array.store_path.store.set(key, chunk) for key, chunk in chunks]
    done = await asyncio.gather(*puts, return_exceptions=True)
    for outcome in done:
        if isinstance(outcome, BaseException):
            raise outcome


def _whole_chunks(
    array: Any, where: tuple[slice, ...], values: np.ndarray
) -> list[tuple[str, Any]] | None:
    """The chunks of ``array`` that region ``where`` covers whole, as (store key, encoded
    bytes), encoded by the array's own codecs (as zarr writes them, empty ones too); None
    where zarr must write it: a region cutting a chunk, a chunk grid or codec that encodes
    only asynchronously (sharding), a Zarr v2 array. The array's last chunk in a dimension
    may stick out of the array: zarr stores it whole, filled with the fill value, and so
    does this."""
    from zarr.core.buffer import default_buffer_prototype
    from zarr.core.chunk_grids import RegularChunkGrid

    meta = array.metadata
    codecs: list[Any] = list(getattr(meta, "codecs", None) or [])
    if (
        meta.zarr_format != 3
        or not isinstance(meta.chunk_grid, RegularChunkGrid)
        or not codecs
        or not all(hasattr(c, "_encode_sync") for c in codecs)
    ):
        return None
    size, shape = meta.chunk_grid.chunk_shape, array.shape
    if len(where) != len(shape):
        return None
    ranges, lows = [], []
    for region, n, s in zip(where, size, shape, strict=True):
        lo, hi, step = region.indices(s)
        if step != 1 or lo % n or (hi % n and hi != s):
            return None
        ranges.append(range(lo // n, -(-hi // n)))
        lows.append(lo)
    prototype = default_buffer_prototype()
    out = []
    for coords in itertools.product(*ranges):
        part = tuple(
            slice(c * n - lo, min((c + 1) * n, s) - lo)
            for c, n, s, lo in zip(coords, size, shape, lows, strict=True)
        )
        block = values[part]
        if block.shape != tuple(size):
            whole = np.full(size, meta.fill_value, dtype=block.dtype)
            whole[tuple(slice(0, k) for k in block.shape)] = block
            block = whole
        spec = meta.get_chunk_spec(coords, array.config, prototype)
        encoded = prototype.nd_buffer.from_numpy_array(np.ascontiguousarray(block))
        for codec in codecs:
            encoded = codec._encode_sync(encoded, spec)
            spec = codec.resolve_metadata(spec)
        key = meta.encode_chunk_key(coords)
        out.append((f"{array.store_path.path}/{key}" if array.store_path.path else key, encoded))
    return out


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
