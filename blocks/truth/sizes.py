"""Size bounds on truth files, checked from what a file declares before its data are read.

A radar file or a grid declares its sizes (an ODIM sweep's ``nbins``, a netCDF dimension, an
HDF5 dataset's shape) in a few bytes; a compressed file of zeros, or one header number
changed, declares gigabytes in kilobytes. The readers allocate what is declared (xradar's
ODIM backend builds the range axis from ``nbins``: ``nbins`` = 1e9 took 13.9 GB), so the
declarations are checked first, against bounds no real file comes near and against the
memory the process may use:

* a sweep: at most :data:`MAX_GATES` gates a ray (32,768: 15 m gates to 490 km) and
  :data:`MAX_RAYS` rays (20,000: a sweep of 0.02 deg rays);
* a gridded truth: at most :data:`MAX_GRID_POINTS` points a field (2^28, 268 million: a
  model grid of 1000 x 1000 x 268; a convection-permitting model's is about 1e8);
* anything: its values decoded (8 bytes a value, as the readers decode them) within half of
  the memory available (:func:`pasim_graph.resources.memory_available`).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

MAX_GATES = 32_768
MAX_RAYS = 20_000
MAX_GRID_POINTS = 1 << 28
#: Bytes a decoded value takes in the readers (float64 before the truth keeps float32).
DECODED_BYTES = 8


class SizeError(ValueError):
    """A file declaring more than it may: refused before reading, naming the file."""


def _memory_bound() -> int:
    from pasim_graph.resources import memory_available

    return memory_available() // 2


def _gib(n: float) -> str:
    return f"{n / 2**30:.1f} GiB"


def check_total(where: str, values: int) -> None:
    """Refuse ``values`` decoded values that would not fit half the available memory."""
    need = values * DECODED_BYTES
    bound = _memory_bound()
    if need > bound:
        raise SizeError(
            f"{where}: declares {values:,} values, {_gib(need)} decoded, more than half the "
            f"memory available ({_gib(2 * bound)}); refused before reading"
        )


def check_sweep(where: str, rays: int, gates: int) -> None:
    """Refuse a sweep declaring more rays or gates than any radar measures."""
    if gates > MAX_GATES or rays > MAX_RAYS or gates < 0 or rays < 0:
        raise SizeError(
            f"{where}: declares {rays:,} rays of {gates:,} gates; a sweep has at most "
            f"{MAX_RAYS:,} rays of {MAX_GATES:,} gates (refused before reading)"
        )


def _as_int(value: Any) -> int | None:
    import numpy as np

    array = np.asarray(value).ravel()
    if array.size != 1 or array.dtype.kind not in "iuf":
        return None
    number = float(array[0])
    return int(number) if np.isfinite(number) else None


def check_hdf5(path: Path, shown: Path | None = None) -> None:
    """An HDF5 radar file (ODIM_H5, GAMIC, CfRadial as netCDF-4): every ``nbins``/``nrays``
    attribute (ODIM's ``where``, GAMIC's ``how``) and every dataset's declared shape, before
    xradar reads any of it. ``shown`` names the file (a gzip-wrapped file's own name)."""
    import h5py

    name = shown or path
    total = 0
    with h5py.File(path, "r") as f:
        items: list[tuple[str, Any]] = []
        f.visititems(lambda key, obj: items.append((key, obj)))
        for key, obj in [("/", f), *items]:
            attrs = obj.attrs
            rays = _as_int(attrs["nrays"]) if "nrays" in attrs else None
            gates = _as_int(attrs["nbins"]) if "nbins" in attrs else None
            if gates is None and "bin_count" in attrs:
                gates = _as_int(attrs["bin_count"])
            if rays is None and "ray_count" in attrs:
                rays = _as_int(attrs["ray_count"])
            if rays is not None or gates is not None:
                check_sweep(f"{name}: {key}", rays or 0, gates or 0)
            if isinstance(obj, h5py.Dataset) and len(obj.shape) >= 2:
                rows, cols = int(obj.shape[-2]), int(obj.shape[-1])
                # a CfRadial file's (time, range) holds all its sweeps' rays
                check_sweep(f"{name}: dataset {key} of shape {obj.shape}", rows // 50, cols)
            if isinstance(obj, h5py.Dataset):
                total += int(obj.size)
    check_total(str(name), total)


def check_netcdf3(path: Path, shown: Path | None = None) -> None:
    """A netCDF classic file (CfRadial 1): its dimensions and variables' declared sizes."""
    import netCDF4

    name = shown or path
    with netCDF4.Dataset(path) as nc:
        dims = {d: len(v) for d, v in nc.dimensions.items()}
        gates = dims.get("range", 0)
        rays = max(dims.get("time", 0), dims.get("n_points", 0) // max(gates, 1))
        if gates > MAX_GATES:
            check_sweep(f"{name}: dimension range", 0, gates)
        total = 0
        for var in nc.variables.values():
            size = 1
            for d in var.dimensions:
                size *= dims.get(d, 1)
            total += size
    if rays > 50 * MAX_RAYS:  # a volume of many sweeps holds many sweeps' rays
        check_sweep(f"{name}: dimension time", rays, 0)
    check_total(str(name), total)


def check_zarr(path: Path) -> None:
    """A Zarr store (a CfRadial 2 volume, a gridded truth): every array's declared shape from
    its metadata (``zarr.json``, or ``.zarray`` of Zarr 2), before xarray opens it (xarray
    reads an index coordinate, ``range`` among them, whole at the open)."""
    import json

    total = 0
    for meta in sorted([*path.rglob("zarr.json"), *path.rglob(".zarray")]):
        try:
            node = json.loads(meta.read_text()[: 1 << 20])
        except (OSError, ValueError):
            continue  # the reader names a damaged store
        if not isinstance(node, dict) or (
            meta.name == "zarr.json" and node.get("node_type") != "array"
        ):
            continue
        shape = [int(n) for n in node.get("shape", []) if isinstance(n, int | float)]
        name = str(meta.parent.relative_to(path))
        if len(shape) == 2:
            check_sweep(f"{path}: {name} of shape {tuple(shape)}", shape[0], shape[1])
        elif len(shape) == 1 and meta.parent.name == "range":
            check_sweep(f"{path}: {name}", 0, shape[0])
        size = 1
        for n in shape:
            size *= n
        if size > MAX_GRID_POINTS:
            raise SizeError(
                f"{path}: {name} declares {' x '.join(map(str, shape))} = {size:,} values, "
                f"more than {MAX_GRID_POINTS:,}; refused before reading"
            )
        total += size
    check_total(str(path), total)


def check_tree(where: str, sweeps: Iterable[Any]) -> None:
    """An opened (lazy) radar file's sweeps, before their data are loaded: each sweep's
    azimuth and range sizes and the values of all its variables."""
    total = 0
    for name, ds in sweeps:
        sizes = dict(ds.sizes)
        check_sweep(f"{where}, {name}", int(sizes.get("azimuth", 0)), int(sizes.get("range", 0)))
        total += sum(int(v.size) for v in ds.variables.values())
    check_total(where, total)


def check_grid(where: str, fields: dict[str, tuple[tuple[str, ...], tuple[int, ...]]]) -> None:
    """A gridded truth's fields (name -> (dims, shape)) before their values are read."""
    total = 0
    for var, (dims, shape) in fields.items():
        points = 1
        for n in shape:
            points *= int(n)
        if points > MAX_GRID_POINTS:
            raise SizeError(
                f"{where}: {var} declares {' x '.join(map(str, shape))} = {points:,} points "
                f"on ({', '.join(dims)}), more than {MAX_GRID_POINTS:,} (a model grid's are "
                "about 1e8); refused before reading"
            )
        total += points
    check_total(where, total)


__all__ = [
    "MAX_GATES",
    "MAX_GRID_POINTS",
    "MAX_RAYS",
    "SizeError",
    "check_grid",
    "check_hdf5",
    "check_netcdf3",
    "check_sweep",
    "check_total",
    "check_tree",
    "check_zarr",
]
