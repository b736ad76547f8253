"""Sweep-level blocks: run once per sweep, on the whole sweep, after its chunks are written.

An algorithm that needs neighbouring radials (region-based velocity dealiasing, a despeckle
filter) cannot run chunk by chunk. A block class that sets ``sweep_level = True`` runs in this
stage instead, with typed ports like any other block:

- its inputs are the outputs of once-per-run blocks, the *stored* outputs of per-chunk blocks
  read back from the sweep (the variables of that output's schema the sweep holds, with the
  sweep's coordinates, its beams along ``beam`` again), or the outputs of sweep-level blocks
  before it; ``process`` gets the whole sweep as one chunk (every beam of it);
- its stored outputs are written into the sweep's group as new arrays, chunked along the beams
  as the rest of the sweep, and the group's attribute :data:`STAGE_DONE` is set last.

A stored run runs the stage of each sweep once every chunk of the run is written, in the
process that writes the store. ``--resume`` runs it for every sweep whose flag is not set, or
one of whose chunks it wrote again; a finished stage is not run again. Since the stage sees the
stored sweep, its numbers do not depend on the chunking. The engine knows nothing about what
the blocks compute.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .fm301 import BEAM_DIMENSIONS
from .ports import BEAM_DIM
from .sweep_level import run_stage, stored_inputs

if TYPE_CHECKING:
    import xarray as xr

#: Attribute of a sweep group: "true" once every sweep-level block of the sweep has written.
STAGE_DONE = "pasim_sweep_stage_done"


def stage_arrays(plan: Any, arrays: list[str]) -> list[str]:
    """Those of ``arrays`` (paths in a store, ``sweep_0/NAME``) that a sweep-level block of
    ``plan`` writes: gone, they are written again by running the stage again, not by laying
    out the sweep again (the layout does not hold them)."""
    names: set[str] = set()
    for block in plan.sweep_level:
        for port in plan.sinks.get(block, []):
            schema = plan.graph.classes[block].outputs[port].type.schema
            names |= set(schema.variables) if schema else set()
    return [a for a in arrays if "/" in a and a.split("/", 1)[1] in names]


def stage_done(path: str, group: str) -> bool:
    """True when the sweep stage of ``group`` in the store at ``path`` finished."""
    import zarr

    try:
        node = zarr.open_group(str(path), path=group, mode="r", use_consolidated=False)
    except Exception:
        return False
    return node.attrs.get(STAGE_DONE) == "true"


def write_stage(path: str, group: str, outputs: list[xr.Dataset], chunk_beams: int) -> list[str]:
    """Write the stage's ``outputs`` into ``group`` (replacing arrays of an earlier try of it),
    then set the group's :data:`STAGE_DONE`; returns the arrays written."""
    import xarray as xr
    import zarr

    from .store import array_list, encoding, quiet_zarr_warnings

    node = zarr.open_group(str(path), path=group, mode="r+", use_consolidated=False)
    node.attrs.pop(STAGE_DONE, None)
    stored_dim = next(d for d in BEAM_DIMENSIONS if d in _dims(node))
    merged = xr.merge(outputs, compat="override", join="override", combine_attrs="override")
    merged = merged.drop_vars(list(merged.coords)).rename_dims({BEAM_DIM: stored_dim})
    names = [str(n) for n in merged.data_vars]
    for name in names:
        if name in node:
            del node[name]
    enc = {}
    for name in names:
        var = merged[name]
        chunks = tuple(
            min(chunk_beams, var.sizes[d]) if d == stored_dim else var.sizes[d] for d in var.dims
        )
        enc[name] = {**encoding(var.dtype), "chunks": chunks}
    # xarray writes a Dataset's attributes over the group's: the group's own are kept.
    merged.attrs = dict(node.attrs)
    with quiet_zarr_warnings():
        merged.to_zarr(
            path, group=group, mode="a", consolidated=False, encoding=enc, write_empty_chunks=True
        )
        root = zarr.open_group(str(path), mode="r+", use_consolidated=False)
        root.attrs.update(array_list(path))
        node = zarr.open_group(str(path), path=group, mode="r+", use_consolidated=False)
        node.attrs[STAGE_DONE] = "true"
    return [f"{group}/{n}" for n in names]


def _dims(node: Any) -> set[str]:
    out: set[str] = set()
    for _, array in node.arrays():
        out |= set(array.metadata.dimension_names or ())
    return out


def run_stored_stage(
    executor: Any,
    static: dict[tuple[str, str], Any],
    path: str,
    group: str,
    chunk_beams: int,
) -> None:
    """Read the finished chunks of sweep ``group`` back from the store at ``path``, run the
    sweep-level blocks on it and write their outputs (:func:`write_stage`)."""
    import xarray as xr

    from .store import quiet_zarr_warnings

    with quiet_zarr_warnings():
        stored = xr.open_zarr(path, group=group, consolidated=False)
        wanted = stored_inputs(executor.plan)
        sweep = stored[[n for n in stored.data_vars if n in wanted]].load()
    write_stage(path, group, run_stage(executor, static, sweep), chunk_beams)
