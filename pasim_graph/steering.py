"""Every beam of a scan held to every block that must point at it, before any work.

A block that cannot reach some directions (a planar array's face sees only the half-space in
front of it) says so through :meth:`~pasim_graph.block.Block.steering_problems`. Validation
asks it with the scan's nominal beams (built from the beam source alone, without its truth),
so ``pasim validate``, ``pasim run`` and a study's ``--check`` refuse such a graph before
anything is read or written; the executor asks again with the beams as aligned to the truth
(a beam moves by up to half a truth radial), before the first chunk.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from .block import Block, Chunk
from .graphfile import GraphSpec, Problem


class Graph(Protocol):
    """What this module reads of a :class:`pasim_graph.graph.Graph` (which validates with
    this module, so is not imported here)."""

    spec: GraphSpec
    classes: dict[str, type[Block]]
    params: dict[str, dict[str, Any]]

    def at_expected_level(self) -> bool: ...


class SteeringError(ValueError):
    """Beams of the scan that a block cannot point at; every problem in one line."""


def steerers(graph: Graph) -> list[str]:
    """The blocks of ``graph`` whose class checks the beams it is pointed at."""
    return [
        name
        for name, cls in graph.classes.items()
        if any("steering_problems" in vars(k) for k in cls.__mro__ if k is not Block)
    ]


def beam_problems(
    graph: Graph, sweep: int, n_sweeps: int, azimuth: Any, elevation: Any
) -> list[Problem]:
    """What the blocks of ``graph`` say of the beams of one sweep (azimuth, elevation in
    deg), each a problem located at the block's line."""
    az = np.asarray(azimuth, dtype=float).ravel()
    el = np.broadcast_to(np.asarray(elevation, dtype=float), np.shape(azimuth)).ravel()
    where = f" (sweep {sweep} of {n_sweeps})" if n_sweeps > 1 else ""
    out = []
    for name in steerers(graph):
        cls = graph.classes[name]
        for item, message in cls.steering_problems(graph.params[name], az, el):
            out.append(
                Problem(graph.spec.file, graph.spec.blocks[name].line, name, item, message + where)
            )
    return out


def nominal_problems(graph: Graph) -> list[Problem]:
    """The steering problems of every sweep's nominal beams (none where no block checks).

    The beam source is built for each sweep and run on all its beams without its inputs (a
    truth only aligns the beams); a beam source that cannot be built or run so is left to
    the run, which names its failure.
    """
    if not steerers(graph):
        return []
    source = next(n for n, c in graph.classes.items() if c.beam_source)
    cls = graph.classes[source]
    params = dict(graph.params[source])
    problems: list[Problem] = []
    try:
        sweeps = cls.scan_sweeps(dict(params)) or [{}]
    except Exception:
        return []
    for k, overrides in enumerate(sweeps):
        try:
            block = cls(name=source, **{**params, **overrides})
            beams = np.arange(block.beam_count())
            chunk = Chunk(
                beams=beams,
                seed=0,
                block_name=source,
                resource=block.load(),
                sweep=k,
                expected=graph.at_expected_level(),
            )
            out = block.process({}, chunk)
            ds = out[next(iter(cls.outputs))]
            azimuth, elevation = steered(ds)
        except Exception:
            return problems
        problems += beam_problems(graph, k, len(sweeps), azimuth, elevation)
    return problems


def steered(beams: Any) -> tuple[Any, Any]:
    """Where the beams are steered in the antenna's own frame: ``array_azimuth`` and
    ``array_elevation`` when the beam source gives them (a scan on a moving platform), else
    ``azimuth`` and ``elevation``."""
    if "array_azimuth" in beams:
        return beams["array_azimuth"].values, beams["array_elevation"].values
    return beams["azimuth"].values, beams["elevation"].values


def check_beams(graph: Graph, sweep: int, n_sweeps: int, beams: Any) -> None:
    """Raise :class:`SteeringError` when a block cannot point at the beams of one sweep
    (``beams``: what the beam source gives for all of them, truth-aligned)."""
    problems = beam_problems(graph, sweep, n_sweeps, *steered(beams))
    if problems:
        raise SteeringError("; ".join(map(str, problems)))
