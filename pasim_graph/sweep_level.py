"""Which blocks are sweep-level, what they may be connected to, and running them on a sweep
held in memory; :mod:`.sweep_stage` runs them on a stored sweep (the overview is there).

Nothing here reads or writes a store, so that validation (:mod:`.graph`) and the in-memory
executor use it without the store's imports.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .ports import BEAM_DIM

if TYPE_CHECKING:
    import xarray as xr

    from .block import Block


def is_sweep_level(cls: type[Block]) -> bool:
    """True when the block class runs once per sweep, after the sweep's chunks."""
    return bool(getattr(cls, "sweep_level", False))


def stage_problems(classes: dict[str, type[Block]], edges: list[Any]) -> list[tuple[str, str]]:
    """Connections a sweep stage cannot serve, as ``(block, message)`` pairs: a sweep-level
    block reads a per-chunk output that is not stored, or a block that is not sweep-level
    reads a sweep-level block's output (which exists only after every chunk)."""
    out = []
    for e in edges:
        src, dst = classes.get(e.src), classes.get(e.dst)
        if src is None or dst is None:
            continue
        if is_sweep_level(src) and not is_sweep_level(dst):
            out.append(
                (
                    e.dst,
                    f"input '{e.dst_port}' reads {e.src}.{e.src_port}, the output of a "
                    "sweep-level block (made once per sweep, after its chunks): only another "
                    "sweep-level block can read it",
                )
            )
        elif (
            is_sweep_level(dst)
            and not is_sweep_level(src)
            and src.runs_per_chunk()
            and not src.outputs[e.src_port].store
        ):
            out.append(
                (
                    e.dst,
                    f"input '{e.dst_port}' of a sweep-level block reads {e.src}.{e.src_port}, "
                    "which is computed per chunk and not stored: a sweep-level block reads "
                    "the sweep as stored (connect a stored output)",
                )
            )
    return out


def beam_dimension_of(sweep: xr.Dataset) -> str:
    """The dimension the beams of ``sweep`` run along (``beam`` before the store names it)."""
    for name in (BEAM_DIM, "azimuth", "elevation", "time"):
        if name in sweep.dims:
            return name
    raise ValueError("a sweep needs a beam, azimuth, elevation or time dimension")


def stored_value(sweep: xr.Dataset, cls: type[Block], port: str) -> xr.Dataset:
    """The value of the stored output ``port`` of a per-chunk block of class ``cls``, taken
    back from the whole ``sweep``: the variables of its schema that the sweep holds, the
    sweep's coordinates and attributes, its beams along ``beam``."""
    dim = beam_dimension_of(sweep)
    if dim != BEAM_DIM:
        sweep = sweep.swap_dims({dim: BEAM_DIM})
    schema = cls.outputs[port].type.schema
    names = [n for n in (schema.variables if schema else {}) if n in sweep.data_vars]
    return sweep[names]


def stored_inputs(plan: Any) -> set[str]:
    """The variables of a stored sweep that the sweep-level blocks of ``plan`` read (those of
    the schemas of the per-chunk outputs that feed them): the stage loads only these (not the
    I/Q cubes of a run with ``--save-iq``)."""
    out: set[str] = set()
    for name in plan.sweep_level:
        for e in plan.graph.inputs_of(name):
            cls = plan.graph.classes[e.src]
            if e.src in plan.per_chunk and not is_sweep_level(cls):
                schema = cls.outputs[e.src_port].type.schema
                out |= set(schema.variables) if schema else set()
    return out


def run_stage(executor: Any, static: dict[tuple[str, str], Any], sweep: xr.Dataset) -> list[Any]:
    """Run the sweep-level blocks of ``executor`` (a :class:`.executor.LocalExecutor`, one
    sweep's) on the whole ``sweep`` (as merged or as stored) and return their stored outputs,
    beams along ``beam``."""
    plan = executor.plan
    values: dict[tuple[str, str], Any] = dict(static)
    for name in plan.sweep_level:
        for e in plan.graph.inputs_of(name):
            if (e.src, e.src_port) not in values:
                values[(e.src, e.src_port)] = stored_value(
                    sweep, plan.graph.classes[e.src], e.src_port
                )
    n_beams = sweep.sizes[beam_dimension_of(sweep)]
    for name in plan.sweep_level:
        executor._run_block(name, values, np.arange(n_beams))
    out = []
    for name in plan.sweep_level:
        for port in plan.sinks.get(name, []):
            if (name, port) in values:
                out.append(values[(name, port)])
    return out
