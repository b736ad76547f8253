"""The run product: a radar volume in the WMO FM-301 / CfRadial 2 layout, written to Zarr.

The root group holds the site and the run's provenance; ``sweep_0`` holds the beams along
``azimuth`` with ``range``, as xradar models a sweep, so ``xarray.open_datatree(store,
engine="zarr")`` opens it and xradar and Py-ART can use it.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .ports import BEAM_DIM
from .scores import summarize as summarize  # re-exported: callers score a sweep from here
from .scores import sweep_names
from .store_check import (
    DamagedStoreError,
    NotAStoreError,
    array_list,
    check_arrays,
    check_chunks,
    some,
    symbolic_links,
)
from .store_lock import LOCK, StoreError, StoreLock, current_writer, describe_holder
from .stored_values import writes_raw

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


def open_store(path: str | Path, *, overwrite: bool, resume: bool, command: str) -> StoreLock:
    """Take a directory for a run to write, refusing anything this program did not write.

    ``path`` may be missing or an empty directory (a new store), or a store of ours: with
    ``overwrite`` it is marked for replacement (emptied by :func:`replace_store` only once
    the new run is ready to write, so a run that fails first leaves it as it was), with
    ``resume`` it is kept for the run to complete; without either an existing store is
    refused. An overwrite is refused, naming them, when the store holds files this program
    did not write there (a user's notes or plots). A plain file, a non-empty
    directory without the marker (``.``, a home folder, a foreign Zarr), a store another
    run is writing, or a place that cannot be written raise :class:`StoreError` naming the
    path, before anything in it is touched. Returns the held lock.
    """
    path = Path(path)
    if overwrite and resume:
        raise StoreError("--resume and --overwrite exclude each other: choose one")
    if path.exists() and not path.is_dir():
        raise StoreError(f"{path} is a file, not a store directory; choose another --out")
    # A store another run is just making holds only its lock and a marker it may not have
    # finished writing: then the lock decides (and names that run).
    if path.is_dir() and not is_store(path) and set(_entries(path)) - {LOCK, MARKER}:
        what = (
            "a Zarr store written by something else"
            if (path / "zarr.json").exists()
            else ("a directory this program did not write")
        )
        raise StoreError(
            f"{path} is {what} (no {MARKER} in it); it is left untouched: choose another --out"
        )
    made_dirs = [p for p in (path, *path.parents) if not p.exists()]
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StoreError(f"cannot create {path}: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        readonly = bool(os.statvfs(path).f_flag & os.ST_RDONLY)
        why = "the file system is read-only" if readonly else "permission denied"
        raise StoreError(f"cannot write to {path}: {why}")
    lock = StoreLock.acquire(path, command)
    lock.made_dirs = made_dirs
    try:
        # Checked again under the lock: another run may have made the store meanwhile.
        existing = set(_entries(path)) - {LOCK}
        if existing and not is_store(path):
            raise StoreError(f"{path} is not a store this program wrote; choose another --out")
        if existing and not (overwrite or resume):
            crashed = " (a run that stopped early left it)" if lock.previous else ""
            raise StoreExistsError(
                f"{path} exists{crashed}; pass --resume to complete it or --overwrite to replace it"
            )
        links = symbolic_links(path) if existing and resume else []
        if links:
            raise StoreError(
                f"{path} holds symbolic links ({some(links)}); --resume would write through "
                "them, outside the store: remove them, or choose another --out"
            )
        if existing and overwrite:
            foreign = foreign_entries(path)
            if foreign:
                raise StoreError(
                    f"{path} holds files this program did not write ({some(foreign)}); "
                    "--overwrite would delete them: move them out of the store, or choose "
                    "another --out"
                )
            if run_state(path) is None:
                clear_store(path)  # nothing of a finished run to keep (a template cut short)
                existing = set()
            else:
                lock.replacing = True
        if not existing:
            from . import __version__

            lock.fresh = True
            (path / MARKER).write_text(
                json.dumps({"format": _MARKER_FORMAT, "writer": f"pasim-graph {__version__}"})
                + "\n"
            )
    except BaseException:
        lock.release(restore=True)
        raise
    return lock


def replace_store(lock: StoreLock) -> None:
    """Empty a store taken with --overwrite, now that the new run is about to write it."""
    if lock.replacing:
        clear_store(lock.path.parent)
        lock.replacing = False
        lock.fresh = True


def discard_store(lock: StoreLock) -> None:
    """Undo a fresh store that holds nothing yet (its run failed before writing anything):
    remove the marker, the lock, and the directories the run made for it."""
    store = lock.path.parent
    if not (lock.fresh and is_store(store)) or run_state(store) is not None:
        return
    # zarr writes a layout's files concurrently: when one write failed, others may still be
    # landing. Wait until the tree is still, so nothing is written after it is removed.
    settle(store)
    clear_store(store)
    (store / MARKER).unlink()
    lock.release()
    for made in lock.made_dirs:
        try:
            made.rmdir()
        except OSError:
            break  # not empty: something else is in it now


def settle(path: Path, quiet_s: float = 0.2, limit_s: float = 5.0) -> None:
    """Wait until nothing under ``path`` has changed for ``quiet_s`` (at most ``limit_s``)."""

    def snapshot() -> set[tuple[str, int, int]]:
        out = set()
        for dirpath, _, files in os.walk(path):
            for name in files:
                with contextlib.suppress(OSError):
                    st = os.lstat(os.path.join(dirpath, name))
                    out.add((os.path.join(dirpath, name), st.st_size, st.st_mtime_ns))
        return out

    start, last = time.monotonic(), snapshot()
    while time.monotonic() - start < limit_s:
        time.sleep(quiet_s)
        now = snapshot()
        if now == last:
            return
        last = now


def clear_store(path: Path) -> None:
    """Remove a store's contents but its marker and lock (only ever called on our stores)."""
    if not is_store(path):
        raise StoreError(f"{path} is not a store this program wrote; refusing to clear it")
    for name in set(_entries(path)) - {LOCK, MARKER}:
        entry = path / name
        if entry.is_dir() and not entry.is_symlink():
            _rmtree(entry)
        else:
            entry.unlink(missing_ok=True)


def _rmtree(path: Path) -> None:
    """Remove a tree; files that vanish meanwhile are fine (zarr's writer threads of a run
    that failed may still be renaming their partial files into place)."""
    import sys

    def missing_ok(func: Any, name: str, exc: Any) -> None:
        err = exc if isinstance(exc, BaseException) else exc[1]
        if not isinstance(err, FileNotFoundError):
            raise err

    if sys.version_info >= (3, 12):
        shutil.rmtree(path, onexc=missing_ok)
    else:
        shutil.rmtree(path, onerror=missing_ok)


def foreign_entries(path: Path) -> list[str]:
    """Entries of a store that this program did not write, relative to it (sorted).

    A store holds its marker, its lock and a Zarr v3 hierarchy: groups (a ``zarr.json`` and
    child nodes) and arrays (a ``zarr.json`` and their chunks under ``c``). Anything else was
    put there by someone else.
    """

    def walk(node: Path, rel: str) -> list[str]:
        out: list[str] = []
        try:
            meta = json.loads((node / "zarr.json").read_text())
        except (OSError, ValueError):
            meta = {}
        is_array = isinstance(meta, dict) and meta.get("node_type") == "array"
        for entry in sorted(node.iterdir(), key=lambda e: e.name):
            name = f"{rel}{entry.name}"
            if entry.name == "zarr.json" or (not rel and entry.name in (MARKER, LOCK)):
                continue
            if is_array:
                # chunks live under c/ (c itself for a 0-d array)
                if entry.name != "c" or entry.is_symlink():
                    out.append(name)
            elif entry.is_dir() and not entry.is_symlink() and (entry / "zarr.json").exists():
                out += walk(entry, name + "/")
            else:
                out.append(name)
        return out

    try:
        return walk(path, "")
    except OSError as exc:
        raise StoreError(f"cannot read {path}: {exc.strerror or exc}") from None


def _entries(path: Path) -> list[str]:
    try:
        return sorted(e.name for e in path.iterdir())
    except OSError as exc:
        raise StoreError(f"cannot read {path}: {exc.strerror or exc}") from None


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


def split_volume(sweep: xr.Dataset, attrs: dict[str, Any]) -> tuple[xr.Dataset, xr.Dataset]:
    """Name the beam dimension, and move site and volume metadata to a root dataset."""
    if BEAM_DIM in sweep.dims:
        # FM-301: an RHI's beams run along elevation, every other sweep's along azimuth.
        mode = str(sweep["sweep_mode"].values) if "sweep_mode" in sweep.variables else ""
        default = "elevation" if mode == "rhi" else "azimuth"
        beam_dim = str(sweep.attrs.pop("beam_dimension", default))
        sweep = sweep.swap_dims({BEAM_DIM: beam_dim})
    root = xr.Dataset(attrs=dict(attrs))
    for name in _SITE:
        if name in sweep.variables:
            root = root.assign_coords({name: sweep[name].variable})
    for name in _ROOT_VARS:
        if name in sweep.variables:
            root[name] = sweep[name].variable
            sweep = sweep.drop_vars(name)
    if "platform_type" in root and str(root["platform_type"].values) != "fixed":
        # FM-301: a ship's or an aircraft's radar is a mobile platform (provenance's "false"
        # is the still ground radar's).
        root.attrs["platform_is_mobile"] = "true"
    return root, sweep


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
    """Lay out a one-sweep store: :func:`create_sweep` for ``sweep_0``, then
    :func:`create_root` with its ``n_chunks`` done flags."""
    create_sweep(path, "sweep_0", sweep, beam_coords, n_beams, chunk_beams)
    create_root(path, root, n_chunks)


def create_sweep(
    path: str | Path,
    group: str,
    sweep: xr.Dataset,
    beam_coords: dict[str, xr.Variable],
    n_beams: int,
    chunk_beams: int,
) -> None:
    """Write one sweep's metadata and every array that does not depend on the chunks.

    ``sweep`` holds one chunk's data; its beam-dimension variables are laid out at full size
    (``n_beams``), chunked by ``chunk_beams`` so that chunks write disjoint Zarr chunks.
    ``beam_coords`` are the coordinates along the beams for every beam.
    """
    ds = sweep_template(sweep, beam_coords, n_beams, chunk_beams)
    with quiet_zarr_warnings():
        # mode "a", never "w": zarr's "w" empties the whole directory, marker and lock included.
        ds.to_zarr(
            path,
            group=group,
            mode="a",
            consolidated=False,
            compute=False,
            encoding={n: encoding(v.dtype) for n, v in ds.variables.items()},
            write_empty_chunks=True,
        )


def sweep_template(
    sweep: xr.Dataset, beam_coords: dict[str, xr.Variable], n_beams: int, chunk_beams: int
) -> xr.Dataset:
    """A sweep's layout (:func:`create_sweep`): its beam-dimension variables as lazy arrays of
    ``n_beams``, chunked by ``chunk_beams``, the rest as ``sweep`` holds them."""
    import dask.array as da

    beam_dim = beam_dimension(sweep)
    template = {}
    for name, var in sweep.data_vars.items():
        if beam_dim in var.dims:
            shape = tuple(n_beams if d == beam_dim else sweep.sizes[d] for d in var.dims)
            chunks = tuple(chunk_beams if d == beam_dim else sweep.sizes[d] for d in var.dims)
            template[name] = xr.Variable(
                var.dims, da.zeros(shape, dtype=var.dtype, chunks=chunks), var.attrs
            )
        else:
            template[name] = var.variable
    coords = {n: c.variable for n, c in sweep.coords.items() if beam_dim not in c.dims}
    return xr.Dataset(template, coords={**coords, **beam_coords}, attrs=sweep.attrs)


def create_root(path: str | Path, root: xr.Dataset, n_chunks: int) -> None:
    """Write the root group and, last, the done flags of the run's ``n_chunks`` chunks.

    Called after every sweep's layout: until the flags exist the store has no run
    (run_state is None) and is laid out afresh, so a run killed or out of space while writing
    the template never leaves a half layout to resume.
    """
    done = xr.Dataset({DONE: ("pasim_chunk", np.zeros(n_chunks, np.int8))})
    root = root.assign(done)
    root.attrs[COMPLETE] = "false"
    root_encoding = {n: encoding(v.dtype) for n, v in root.variables.items()}
    root_encoding[DONE]["chunks"] = (1,)
    with quiet_zarr_warnings():
        rest = [n for n in root.data_vars if n != DONE]
        root[rest].to_zarr(
            path,
            mode="a",
            consolidated=False,
            encoding={n: e for n, e in root_encoding.items() if n != DONE},
            write_empty_chunks=True,
        )
        # The done flags are the very last thing of the layout: their array existing is what
        # says the template is whole (run_state). The root's attributes, written first, list
        # every array of the layout (ARRAYS), the flags included.
        attrs = {**root.attrs, **array_list(path, DONE)}
        xr.Dataset({DONE: root[DONE]}, attrs=attrs).to_zarr(
            path,
            mode="a",
            consolidated=False,
            encoding={DONE: root_encoding[DONE]},
            write_empty_chunks=True,
        )


def encoding(dtype: np.dtype) -> dict[str, Any]:
    """How every array of a store is written: its own dtype, NaN where nothing was written
    yet (floats and complex), and each chunk zstd-compressed under a CRC-32C checksum, so a
    chunk damaged on disk is an error when read, never a wrong value.

    The dtype is given explicitly, as a guard: a template built with ``da.zeros(shape, dtype)``
    (dask ignores a positional dtype) was float64 and stored the I/Q cubes without their Q
    channel.
    """
    from zarr.codecs import Crc32cCodec, ZstdCodec

    out: dict[str, Any] = {"compressors": [ZstdCodec(level=0), Crc32cCodec()]}
    dtype = np.dtype(dtype)
    if dtype.kind in "fc":
        out["dtype"] = dtype
        out["fill_value"] = complex(np.nan, np.nan) if dtype.kind == "c" else np.nan
    elif dtype.kind in "iub":
        out["dtype"] = dtype
    return out


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
    for name in ("azimuth", "elevation", "time"):
        if name in sweep.dims:
            return name
    raise ValueError("a sweep needs an azimuth, elevation or time dimension")


class IncompleteStoreError(RuntimeError):
    pass


def open_sweep(path: str | Path, index: int = 0) -> tuple[xr.Dataset, dict[str, Any]]:
    """A sweep of a finished run (``sweep_<index>``, the first by default) and its root
    attributes; :func:`open_finished` says what it refuses."""
    tree = open_finished(path)
    return sweep_of(tree, path, index), root_attrs(tree)


def root_attrs(tree: xr.DataTree) -> dict[str, Any]:
    """A volume's root attributes (the run's graph, seed, versions), by name."""
    return {str(k): v for k, v in tree.attrs.items()}


def open_finished(path: str | Path) -> xr.DataTree:
    """A finished run's whole volume, checked.

    Raises :class:`NotAStoreError` naming the path when it is missing, not a store, or a run
    that did not finish, :class:`MissingArraysError` naming the arrays its layout lists that
    are gone, and :class:`DamagedStoreError` naming each damaged array and chunk when its
    files were damaged after they were written (both kinds of it).
    """
    if not Path(path).exists():
        raise NotAStoreError(f"{path}: no such store")
    if is_store(path):
        check_arrays(path)
    state = run_state(path) if is_store(path) else None
    if state is not None and state[0].get(COMPLETE) == "true":
        damage = check_chunks(path)
        if damage:
            raise DamagedStoreError(path, damage)
    try:
        tree = open_volume(path)
    except IncompleteStoreError as exc:
        raise NotAStoreError(str(exc)) from None
    except (OSError, ValueError, KeyError) as exc:
        raise NotAStoreError(f"{path}: not a PASIM-graph store ({exc})") from None
    if "sweep_0" not in tree.children:
        raise NotAStoreError(f"{path}: no sweep_0 group; is this a PASIM-graph store?")
    return tree


def sweep_of(tree: xr.DataTree, path: str | Path, index: int) -> xr.Dataset:
    """Sweep ``index`` of an opened volume; :class:`NotAStoreError` names the sweeps it holds."""
    group = f"sweep_{index}"
    if group not in tree.children:
        raise NotAStoreError(f"{path}: no sweep {index}; it holds {', '.join(sweep_names(tree))}")
    return tree[group].to_dataset()


def open_volume(path: str | Path) -> xr.DataTree:
    """Open a finished run's volume (refuses a run that was interrupted)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
    state = run_state(path)
    if state is not None and state[0].get(COMPLETE) != "true":
        done = int(state[1].sum())
        writer = current_writer(path)
        if writer is not None:
            raise IncompleteStoreError(
                f"{path} is being written now ({done} of {state[1].size} chunks so far) by "
                f"{describe_holder(writer)}; wait for it to finish"
            )
        raise IncompleteStoreError(
            f"{path}: the run did not finish ({done} of {state[1].size} chunks written); "
            "complete it with `pasim run ... --resume`"
        )
    with quiet_zarr_warnings():
        return xr.open_datatree(path, engine="zarr")
