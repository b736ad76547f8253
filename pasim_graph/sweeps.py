"""The sweeps of a run: a scan may declare several (a volume's cuts, a schedule's groups of
beams), each with its own beam-source parameters (elevation, PRT, pulses...). The graph runs
once per sweep with the beam source rebuilt from that sweep's overrides; every other block,
its file I/O and its once-per-run outputs are shared.

The hook is the beam source's class method ``scan_sweeps(params)``
(:meth:`Block.scan_sweeps`), read from the class: the engine never imports the block library.
"""

from __future__ import annotations

import copy
from dataclasses import replace
from typing import Any

from .block import Block
from .executor import BlockError, LocalExecutor, RunOptions
from .graph import Graph


def beam_source(graph: Graph) -> str:
    """The name of the graph's beam source (validation makes sure there is one)."""
    return next(n for n, c in sorted(graph.classes.items()) if c.beam_source)


def sweep_overrides(graph: Graph) -> list[dict[str, Any]]:
    """Each sweep's parameter overrides of the beam source, in scan order (at least one)."""
    name = beam_source(graph)
    cls = graph.classes[name]
    try:
        overrides = list(cls.scan_sweeps(dict(graph.params[name])))
    except Exception as exc:
        raise BlockError(name, cls.type_name, None, exc) from exc
    return overrides or [{}]


def sweep_source(graph: Graph, overrides: dict[str, Any]) -> tuple[Block, int]:
    """The graph's beam source built with one sweep's ``overrides``, and its beams
    (:class:`BlockError` naming it when it cannot be built)."""
    name = beam_source(graph)
    cls = graph.classes[name]
    try:
        block = cls(name=name, **{**graph.params[name], **overrides})
        return block, block.beam_count()
    except Exception as exc:
        raise BlockError(name, cls.type_name, None, exc) from exc


def sweep_beam_counts(graph: Graph) -> list[int]:
    """Each sweep's number of beams, from the beam source alone: no other block is built
    (an antenna's set-up can take a second; a study counts its runs' beams before any)."""
    return [sweep_source(graph, overrides)[1] for overrides in sweep_overrides(graph)]


def for_sweep(base: LocalExecutor, overrides: dict[str, Any], index: int = 0) -> LocalExecutor:
    """``base`` with its beam source rebuilt from ``overrides`` for the sweep at ``index``
    (which keys its random streams): the other blocks, the loaded resources (one dict,
    shared) and the timings are the same objects."""
    if not overrides and index == base.sweep:
        return base
    block, n_beams = sweep_source(base.plan.graph, overrides)
    out = copy.copy(base)
    out.plan = replace(
        base.plan, blocks={**base.plan.blocks, block.name: block}, beam_count=n_beams
    )
    out.sweep = index
    return out


def sweep_executors(graph: Graph, options: RunOptions) -> list[LocalExecutor]:
    """One executor per sweep of the graph's scan, sharing everything but the beam source."""
    base = LocalExecutor(graph, options)
    return [for_sweep(base, o, k) for k, o in enumerate(sweep_overrides(graph))]
