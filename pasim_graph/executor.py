"""Executors: they own storage and parallelism, blocks only describe the work on one chunk.

:class:`LocalExecutor` runs a graph in process, chunk after chunk (the debugging path).
A block whose ports carry no ``beam`` dimension runs once and its outputs are shared by every
chunk; the others run once per chunk of beams. Only the blocks that feed a requested product
run at all. A sweep-level block runs once on the whole sweep, after every chunk
(:mod:`.sweep_stage`).
"""

from __future__ import annotations

import copy
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import networkx as nx
import numpy as np
import xarray as xr

from .block import Block, Chunk
from .duck_arrays import defer_pint_lookup
from .graph import Graph
from .ports import BEAM_DIM
from .steering import check_beams, steerers
from .sweep_level import is_sweep_level, run_stage

# Runs, here and on every Dask worker (which imports this module to run a chunk), never import
# pint for xarray's sake (0.9 s a process).
defer_pint_lookup()


class BlockError(RuntimeError):
    """A block failed while loading or processing; names the block and the beams."""

    def __init__(self, block: str, type_name: str, beams: np.ndarray | None, error: Exception):
        self.block, self.type_name, self.error = block, type_name, error
        where = "while loading" if beams is None else _beams_text(beams)
        if isinstance(error, MemoryError):
            # numpy's MemoryError often says how much it wanted; Python's own says nothing.
            what = f"ran out of memory ({error})" if str(error) else "ran out of memory"
            hint = "; use a smaller --chunk, fewer --workers, or --outputs to compute less"
            text = f"block '{block}' ({type_name}) {what} {where}{hint}"
        else:
            text = f"block '{block}' ({type_name}) failed {where}: {type(error).__name__}: {error}"
        super().__init__(text)


class PortValueError(TypeError):
    """A block returned a value that does not match its output port's declaration."""


def _check_outputs(cls: type[Block], out: Any) -> None:
    """Hold what ``process`` returned to the block's output declarations (metadata only).

    Raises :class:`PortValueError` naming the port and every variable that is missing,
    undeclared or of the wrong dtype, dimensions or units, so that a faulty block fails
    where it is, not in the block that reads its output.
    """
    if not isinstance(out, dict):
        raise PortValueError(f"process() returned {type(out).__name__}, expected a dict by port")
    problems = [
        f"returned an undeclared output {port!r} (outputs: {', '.join(cls.outputs) or 'none'})"
        for port in out
        if port not in cls.outputs
    ]
    for port, value in out.items():
        if port in cls.outputs:
            problems += [f"output port '{port}': {p}" for p in cls.outputs[port].type.check(value)]
    if problems:
        raise PortValueError("; ".join(problems))


def _beams_text(beams: np.ndarray) -> str:
    if beams.size == 0:
        return "(once-per-run step)"
    return f"on beams {int(beams[0])}-{int(beams[-1])}"


@dataclass
class RunOptions:
    """How to run a graph; none of this is part of the graph itself."""

    seed: int = 0
    chunk_beams: int = 8
    save_iq: bool = False
    products: tuple[str, ...] = ("moments",)
    #: Output fields asked for (e.g. ``("DBZH",)``); None asks for every field.
    fields: tuple[str, ...] | None = None

    @property
    def wanted(self) -> set[str]:
        return set(self.products) | ({"iq"} if self.save_iq else set())


@dataclass
class Plan:
    """Which blocks run, in which order, once or per chunk."""

    graph: Graph
    blocks: dict[str, Block]
    static: list[str]
    per_chunk: list[str]
    sinks: dict[str, list[str]]  # block -> its output ports that are written
    beam_count: int
    resources: dict[str, Any] = field(default_factory=dict)
    #: Blocks that run once per sweep on the whole sweep, after its chunks (in order).
    sweep_level: list[str] = field(default_factory=list)
    #: The run is at the expected level (:meth:`Graph.at_expected_level`): every chunk's
    #: ``Chunk.expected``.
    expected: bool = False


def plan(graph: Graph, options: RunOptions) -> Plan:
    """Prune the graph to what the requested products need and build those blocks."""
    sinks: dict[str, list[str]] = {}
    for name, cls in graph.classes.items():
        ports = [p.name for p in cls.outputs.values() if p.store in options.wanted]
        if ports:
            sinks[name] = ports
    if options.fields is not None:
        # --outputs names moments: the sweep-level blocks (which read whole sweeps of them)
        # are not run.
        sinks = {n: ports for n, ports in sinks.items() if not is_sweep_level(graph.classes[n])}
    needed = set(sinks)
    for name in sinks:
        needed |= nx.ancestors(graph.nx, name)
    order = [n for n in graph.order() if n in needed]
    source = next(n for n, c in graph.classes.items() if c.beam_source)
    needed.add(source)
    if source not in order:
        order.insert(0, source)
    blocks = {}
    for n in order:
        cls = graph.classes[n]
        try:
            params = dict(graph.params[n])
            if n == source:
                # A scan of several sweeps runs its first here (pasim_graph.sweeps the rest).
                params.update((cls.scan_sweeps(dict(params)) or [{}])[0])
            blocks[n] = cls(name=n, **params)
        except Exception as exc:
            raise BlockError(n, cls.type_name, None, exc) from exc
    stage = [n for n in order if is_sweep_level(graph.classes[n])]
    static = [n for n in order if not graph.classes[n].runs_per_chunk() and n not in stage]
    per_chunk = [n for n in order if graph.classes[n].runs_per_chunk() and n not in stage]
    return Plan(
        graph,
        blocks,
        static,
        per_chunk,
        sinks,
        blocks[source].beam_count(),
        sweep_level=stage,
        expected=graph.at_expected_level(),
    )


def merge_products(parts: list[xr.Dataset]) -> xr.Dataset:
    """One sweep from the stored Datasets of several blocks (they share their coordinates)."""
    return xr.merge(parts, compat="override", join="override", combine_attrs="override")


def chunks(n_beams: int, size: int) -> Iterator[np.ndarray]:
    size = max(1, int(size))
    for start in range(0, n_beams, size):
        yield np.arange(start, min(start + size, n_beams))


class LocalExecutor:
    """Run a graph in this process, one chunk of beams after another."""

    def __init__(self, graph: Graph, options: RunOptions | None = None):
        self.options = options or RunOptions()
        self.plan = plan(graph, self.options)
        #: Index of the sweep this executor runs (keys the random streams of its beams).
        self.sweep = 0
        #: Seconds each block spent in process() in this process, summed over chunks.
        self.block_seconds: dict[str, float] = {}
        self._lock = threading.Lock()

    def __getstate__(self) -> dict[str, Any]:
        # Sent to dask workers: a lock does not pickle, and each process times its own blocks.
        state = self.__dict__.copy()
        del state["_lock"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def load(self) -> None:
        """Do every block's I/O once (reading the truth file, for example)."""
        for name, block in self.plan.blocks.items():
            try:
                self.plan.resources[name] = block.load()
            except Exception as exc:
                raise BlockError(name, type(block).type_name, None, exc) from exc

    def _run_block(self, name: str, values: dict[tuple[str, str], Any], beams: np.ndarray) -> None:
        p = self.plan
        block = p.blocks[name]
        inputs = {e.dst_port: values[(e.src, e.src_port)] for e in p.graph.inputs_of(name)}
        chunk = Chunk(
            beams=beams,
            seed=self.options.seed,
            block_name=name,
            resource=p.resources.get(name),
            options={"save_iq": self.options.save_iq, "fields": self.options.fields},
            sweep=self.sweep,
            expected=p.expected,
        )
        t0 = time.perf_counter()
        try:
            out = block.process(inputs, chunk)
            _check_outputs(type(block), out)
        except Exception as exc:
            raise BlockError(name, type(block).type_name, beams, exc) from exc
        with self._lock:
            self.block_seconds[name] = self.block_seconds.get(name, 0.0) + (
                time.perf_counter() - t0
            )
        for port in type(block).outputs:
            if port in out:
                values[(name, port)] = out[port]

    def beam_geometry(self, static: dict[tuple[str, str], Any]) -> Any:
        """What the beam source gives for every beam of the scan at once (its first output).

        Cheap: the beam source only describes the beams. Executors lay out a store with it.
        """
        p = self.plan
        source = next(n for n in p.per_chunk if p.graph.classes[n].beam_source)
        values = dict(static)
        self._run_block(source, values, np.arange(p.beam_count))
        return next(v for (b, _), v in values.items() if b == source)

    def check_steering(self, static: dict[tuple[str, str], Any], n_sweeps: int = 1) -> None:
        """Refuse beams a block cannot point at (:mod:`.steering`), before any chunk: the
        beams as aligned to the truth, which validation saw only as nominal."""
        if steerers(self.plan.graph):
            check_beams(self.plan.graph, self.sweep, n_sweeps, self.beam_geometry(static))

    def run_static(self) -> dict[tuple[str, str], Any]:
        values: dict[tuple[str, str], Any] = {}
        for name in self.plan.static:
            self._run_block(name, values, np.arange(0))
        return values

    def for_chunks(self) -> LocalExecutor:
        """This executor as chunk tasks need it (what a Dask worker is sent): the resources of
        the blocks that run per chunk only. A once-per-run block's resource has done its work
        (its outputs travel with the run's shared inputs): the truth file's sweep went to each
        worker twice, 32 MB of the generic radar's 65 MB."""
        trimmed = copy.copy(self)
        keep = {k: v for k, v in self.plan.resources.items() if k in self.plan.per_chunk}
        trimmed.plan = replace(self.plan, resources=keep)
        return trimmed

    def run_chunk(self, static: dict[tuple[str, str], Any], beams: np.ndarray) -> list[xr.Dataset]:
        """Run the per-chunk blocks on ``beams`` and return the datasets to be stored."""
        values = dict(static)
        for name in self.plan.per_chunk:
            self._run_block(name, values, beams)
        return self._products(values, per_beam=True)

    def static_products(self, static: dict[tuple[str, str], Any]) -> list[xr.Dataset]:
        """Stored products that do not depend on the beams (written once)."""
        return self._products(static, per_beam=False)

    def _products(self, values: dict[tuple[str, str], Any], per_beam: bool) -> list[xr.Dataset]:
        out = []
        for name, ports in self.plan.sinks.items():
            for port in ports:
                if (name, port) not in values:
                    continue
                ds = values[(name, port)]
                if (BEAM_DIM in ds.dims) == per_beam:
                    out.append(ds)
        return out

    def run(self, on_chunk: Callable[[int, int], None] | None = None) -> xr.Dataset:
        """Run every chunk and return the merged sweep (beams concatenated in scan order).

        ``on_chunk(done, total)`` is called after each chunk (progress for a caller).
        """
        if not self.plan.resources:
            self.load()
        static = self.run_static()
        self.check_steering(static)
        parts: list[list[xr.Dataset]] = []
        every = list(chunks(self.plan.beam_count, self.options.chunk_beams))
        for beams in every:
            parts.append(self.run_chunk(static, beams))
            if on_chunk is not None:
                on_chunk(len(parts), len(every))
        merged = [
            xr.concat(
                list(group),
                dim=BEAM_DIM,
                data_vars="minimal",
                coords="minimal",
                compat="override",
                join="override",
            )
            for group in zip(*parts, strict=True)
        ]
        merged += self.static_products(static)
        if self.plan.sweep_level:
            merged += run_stage(self, static, merge_products(merged))
        return merge_products(merged)
