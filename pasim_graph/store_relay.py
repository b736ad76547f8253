"""Writing again the arrays a store's layout lists that were removed from it (``--resume``).

A store's root lists every array of its layout (:data:`~pasim_graph.store_check.ARRAYS`). An
array removed whole is laid out again from the run's own layout, as the first run wrote it;
when it holds beams, the chunks of its sweep are then computed again (by the caller), so the
store ends as an uninterrupted run's.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from .store import beam_dimension, encoding, quiet_zarr_warnings
from .store_check import arrays_on_disk


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
