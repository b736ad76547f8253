"""A store's layout: the FM-301 volume a run writes (the root group with the site and the run's
provenance, a group per sweep with its beams), laid out before any chunk runs, every array at
full size; and the arrays of that layout written again when they were removed (``--resume``).

A store's root lists every array of its layout (:data:`~pasim_graph.store.check.ARRAYS`). An
array removed whole is laid out again from the run's own layout, as the first run wrote it;
when it holds beams, the chunks of its sweep are then computed again (by the caller), so the
store ends as an uninterrupted run's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from ..fm301 import (
    PLATFORM_FIXED,
    ROOT_VARIABLES,
    SITE_VARIABLES,
    SWEEP_GROUP_NAME_ATTRS,
    SWEEP_MODE_RHI,
    sweep_group,
)
from ..ports import BEAM_DIM
from .check import array_list, arrays_on_disk
from .format import COMPLETE, DONE, beam_dimension, encoding, quiet_zarr_warnings


def split_volume(sweep: xr.Dataset, attrs: dict[str, Any]) -> tuple[xr.Dataset, xr.Dataset]:
    """Name the beam dimension, and move site and volume metadata to a root dataset."""
    if BEAM_DIM in sweep.dims:
        # FM-301: an RHI's beams run along elevation, every other sweep's along azimuth.
        mode = str(sweep["sweep_mode"].values) if "sweep_mode" in sweep.variables else ""
        default = "elevation" if mode == SWEEP_MODE_RHI else "azimuth"
        beam_dim = str(sweep.attrs.pop("beam_dimension", default))
        sweep = sweep.swap_dims({BEAM_DIM: beam_dim})
    root = xr.Dataset(attrs=dict(attrs))
    for name in SITE_VARIABLES:
        if name in sweep.variables:
            root = root.assign_coords({name: sweep[name].variable})
    for name in ROOT_VARIABLES:
        if name in sweep.variables:
            root[name] = sweep[name].variable
            sweep = sweep.drop_vars(name)
    if "platform_type" in root and str(root["platform_type"].values) != PLATFORM_FIXED:
        # FM-301: a ship's or an aircraft's radar is a mobile platform (provenance's "false"
        # is the still ground radar's).
        root.attrs["platform_is_mobile"] = "true"
    return root, sweep


def create_volume(
    path: str | Path,
    root: xr.Dataset,
    sweep: xr.Dataset,
    beam_coords: dict[str, xr.Variable],
    n_beams: int,
    chunk_beams: int,
    n_chunks: int,
) -> None:
    """Lay out a one-sweep store (:func:`lay_out`)."""
    lay_out(
        path,
        [SweepLayout(sweep_group(0), sweep, beam_coords, n_beams, chunk_beams)],
        root,
        n_chunks,
    )


class SweepLayout(NamedTuple):
    """What :func:`create_sweep` lays out for one sweep."""

    group: str
    sweep: xr.Dataset
    beam_coords: dict[str, xr.Variable]
    n_beams: int
    chunk_beams: int


def lay_out(path: str | Path, sweeps: list[SweepLayout], root: xr.Dataset, n_chunks: int) -> None:
    """Write a store's whole layout: every sweep (:func:`create_sweep`), then the root
    (:func:`create_root`) with the done flags of its ``n_chunks`` chunks last.

    The sweeps and the root's variables are laid out in memory first and their files then
    written to ``path`` through zarr's local store, one after another in the order zarr made
    them: the same files, byte for byte (tests/store/test_layout_writer.py), for half the CPU
    of laying out on disk, where each of a sweep's ~50 arrays costs zarr several reads and
    writes handed to threads (0.45 -> 0.2 s a sweep). The done flags are still written last,
    on disk: until they exist the store has no run and is laid out afresh.
    """
    from zarr.storage import MemoryStore

    staged: dict[str, Any] = {}
    memory = MemoryStore(store_dict=staged)
    for s in sweeps:
        create_sweep(memory, s.group, s.sweep, s.beam_coords, s.n_beams, s.chunk_beams)
    _write_root_variables(memory, root)
    _write_files(path, staged)
    _write_done_flags(path, root, n_chunks)


def _write_files(path: str | Path, files: dict[str, Any]) -> None:
    """Write zarr's buffers ``files`` (key -> Buffer) under ``path``, in order, through zarr's
    local store (a file system's errors, ENOSPC among them, are raised as zarr raises them)."""
    from zarr.core.sync import sync
    from zarr.storage import LocalStore

    store = LocalStore(str(path))

    async def write() -> None:
        # One after another: a failed write leaves no other write still running.
        for key, value in files.items():
            await store.set(key, value)

    sync(write())


def create_sweep(
    path: str | Path | Any,
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
        write_layout(ds, path, group, {str(n): encoding(v.dtype) for n, v in ds.variables.items()})


def write_layout(ds: xr.Dataset, path: str | Path | Any, group: str, enc: dict[str, Any]) -> None:
    """``ds.to_zarr(path, group=group, mode="a", compute=False, ...)``: every array's metadata
    and the values of the arrays ``ds`` holds in memory, none of its lazy arrays' chunks.

    xarray's ``compute=False`` also builds the Dask graph that would write the lazy arrays'
    chunks (hashing each target array by pickling it), which a layout never runs: more than
    half of a layout's CPU (0.44 -> 0.2 s a sweep). The same steps without that graph, through
    the writer xarray's ``to_zarr`` uses; where this xarray has no such writer, ``to_zarr``
    itself. tests/store/test_layout_writer.py checks that both give the same files.
    """
    # mode "a", never "w": zarr's "w" empties the whole directory, marker and lock included.
    options: dict[str, Any] = {"mode": "a", "consolidated": False, "write_empty_chunks": True}
    try:
        from xarray.backends.common import ArrayWriter
        from xarray.backends.writers import dump_to_store, get_writable_zarr_store
    except ImportError:  # pragma: no cover (another xarray: its own path)
        ds.to_zarr(path, group=group, compute=False, encoding=enc, **options)
        return
    store = get_writable_zarr_store(
        str(path) if isinstance(path, (str, Path)) else path, group=group, **options
    )
    try:
        # The writer writes in-memory values at once and keeps the lazy arrays' chunks for a
        # sync that never comes (a chunk task writes its own region later).
        dump_to_store(ds, store, ArrayWriter(), encoding=enc)
    finally:
        store.close()


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
            # Named here: dask would otherwise hash the arguments of every array (a tenth of a
            # small study's CPU), for a graph that is never computed (only its layout is
            # written); the name is unique within the sweep, as a graph's keys must be.
            lazy = da.zeros(shape, dtype=var.dtype, chunks=chunks, name=f"pasim-layout-{name}")
            template[name] = xr.Variable(var.dims, lazy, var.attrs)
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
    _write_root_variables(path, root)
    _write_done_flags(path, root, n_chunks)


def _write_root_variables(store: str | Path | Any, root: xr.Dataset) -> None:
    with quiet_zarr_warnings():
        root = root.copy()
        root.attrs[COMPLETE] = "false"
        root.to_zarr(
            store,
            mode="a",
            consolidated=False,
            encoding={str(n): encoding(v.dtype) for n, v in root.variables.items()},
            write_empty_chunks=True,
        )


def _write_done_flags(path: str | Path, root: xr.Dataset, n_chunks: int) -> None:
    # The done flags are the very last thing of the layout: their array existing is what
    # says the template is whole (run_state). The root's attributes, written first, list
    # every array of the layout (ARRAYS), the flags included.
    done = xr.Dataset({DONE: ("pasim_chunk", np.zeros(n_chunks, np.int8))})
    attrs = {**root.attrs, COMPLETE: "false", **array_list(path, DONE)}
    flags = encoding(done[DONE].dtype)
    flags["chunks"] = (1,)
    with quiet_zarr_warnings():
        xr.Dataset({DONE: done[DONE]}, attrs=attrs).to_zarr(
            path,
            mode="a",
            consolidated=False,
            encoding={DONE: flags},
            write_empty_chunks=True,
        )


def volume_sweeps(sweeps: list[Any]) -> dict[str, Any]:
    """The FM-301 root variables over the volume's sweeps (``sweeps``, xarray Datasets in
    order): ``sweep_group_name`` and each sweep's ``sweep_fixed_angle``, along ``sweep``."""
    names = np.array([sweep_group(k) for k in range(len(sweeps))])
    angles = np.array(
        [
            float(s["sweep_fixed_angle"].values) if "sweep_fixed_angle" in s else np.nan
            for s in sweeps
        ],
        np.float64,
    )
    attrs = dict(sweeps[0]["sweep_fixed_angle"].attrs) if "sweep_fixed_angle" in sweeps[0] else {}
    return {
        "sweep_group_name": xr.Variable("sweep", names, dict(SWEEP_GROUP_NAME_ATTRS)),
        "sweep_fixed_angle": xr.Variable("sweep", angles, attrs),
    }


class RelayError(RuntimeError):
    """A missing array that this run's layout does not hold (the store is another run's)."""


def relay_missing(
    path: str | Path, sweeps: dict[str, xr.Dataset], root: xr.Dataset, missing: list[str]
) -> set[str]:
    """Write again the ``missing`` arrays (their paths in the store) from the run's layout:
    ``sweeps`` by group (:func:`~pasim_graph.store.sweep_template`) and ``root``. Returns the
    sweep groups whose missing arrays hold beams: their chunks must be computed again."""
    by_group: dict[str, list[str]] = {}
    for name in missing:
        group, _, array = name.rpartition("/")
        by_group.setdefault(group, []).append(array)
    layouts = {"": root, **sweeps}
    unknown = [
        f"{group}/{n}".lstrip("/")
        for group, names in by_group.items()
        for n in names
        if group not in layouts or n not in layouts[group].variables
    ]
    if unknown:
        raise RelayError(
            f"{path}: the layout lists {', '.join(unknown)}, which this run does not write; "
            "run it again with --overwrite"
        )
    redo = set()
    for group, names in by_group.items():
        ds = layouts[group]
        _relay(path, group, ds, names)
        beam_dim = beam_dimension(ds) if group else None
        if any(n in ds.data_vars and beam_dim in ds[n].dims for n in names):
            redo.add(group)
    return redo


def _relay(path: str | Path, group: str, ds: xr.Dataset, names: list[str]) -> None:
    """Write arrays ``names`` of ``group`` ("" for the root) as ``ds``, its layout, has them.

    xarray writes the coordinates they share again (the same values) and puts the attributes
    of the whole group: the group's own are put back, so only the arrays change.
    """
    import zarr

    try:
        attrs = dict(zarr.open_group(str(path), path=group, mode="r", use_consolidated=False).attrs)
    except Exception:  # the group went with its arrays: the layout's attributes, then
        attrs = None
    subset = ds[names]
    prefix = f"{group}/" if group else ""
    present = {n.removeprefix(prefix) for n in arrays_on_disk(path) if n.startswith(prefix)}
    new = {n: encoding(v.dtype) for n, v in subset.variables.items() if n not in present}
    with quiet_zarr_warnings():
        subset.to_zarr(
            path,
            group=group or None,
            mode="a",
            consolidated=False,
            compute=False,
            encoding=new,
            write_empty_chunks=True,
        )
        if attrs is not None:
            zarr.open_group(str(path), path=group, mode="r+", use_consolidated=False).attrs.put(
                attrs
            )
