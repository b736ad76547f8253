"""The Dask executor: chunks of beams run in parallel and are written to Zarr as they finish.

Work is described first (one task per chunk of beams), then handed to a scheduler chosen at
run time: dask's threads by default, a ``dask.distributed`` LocalCluster (``workers``) or an
existing cluster (``scheduler`` address). Each task runs the graph on its beams and writes its
region of the store, so memory is bounded by the chunks in flight, not by the sector. Every
random draw is keyed by the run seed and the beam index, so the stored numbers do not depend
on the chunk size, the number of workers or the order chunks finish in.

A run writes the store's template first, then each chunk's region followed by its done flag,
and the completion marker last: a run killed at any moment leaves a store that says it is
incomplete, and ``resume=True`` runs only the chunks whose flag is not set.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import shutil
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .block import Block
from .executor import LocalExecutor, RunOptions, chunks, merge_products
from .graph import Graph
from .store import (
    COMPLETE,
    StoreExistsError,
    beam_dimension,
    create_volume,
    mark_complete,
    run_state,
    split_volume,
    write_region,
)


class ResumeError(RuntimeError):
    """The store cannot be resumed by this run (another graph, seed or chunking)."""


@dataclass
class RunReport:
    chunks_total: int
    chunks_run: int
    beams: int
    seconds_setup: float = 0.0  # reading inputs, once-per-run blocks, the store's layout
    seconds_chunks: float = 0.0  # running and writing the chunks


def run_key(graph: Graph, options: RunOptions) -> str:
    """What must match for a store to be resumed: the graph as run, seed, chunking, products."""
    text = json.dumps(
        {
            "graph": graph.text(),
            "seed": options.seed,
            "chunk_beams": options.chunk_beams,
            "products": sorted(options.wanted),
            "fields": sorted(options.fields) if options.fields is not None else None,
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _warm_up(classes: list[type[Block]]) -> None:
    for cls in classes:
        cls.warm_up()


def _run_and_write(
    executor: LocalExecutor,
    static: dict,
    beams: np.ndarray,
    index: int,
    path: str,
    attrs: dict[str, Any],
) -> int:
    """One task: run the graph on a chunk of beams and write its region (on a worker)."""
    _, sweep = split_volume(merge_products(executor.run_chunk(static, beams)), attrs)
    write_region(path, sweep, int(beams[0]), index)
    return index


class DaskExecutor:
    """Run a graph chunk by chunk with Dask, writing a resumable CfRadial-2 Zarr store.

    Parameters
    ----------
    graph : Graph
        A validated graph.
    options : RunOptions
        Seed, chunk size, products.
    workers : int, optional
        Start a ``dask.distributed`` LocalCluster with this many single-threaded workers.
    scheduler : str, optional
        Address of an existing ``dask.distributed`` scheduler (``tcp://host:8786``).
    progress : bool
        Show dask's progress bar.
    """

    def __init__(
        self,
        graph: Graph,
        options: RunOptions | None = None,
        *,
        workers: int | None = None,
        scheduler: str | None = None,
        progress: bool = False,
    ):
        self.graph = graph
        self.options = options or RunOptions()
        self.local = LocalExecutor(graph, self.options)
        self.workers, self.scheduler, self.progress = workers, scheduler, progress
        self._cluster: Any = None

    def run(
        self,
        path: str | Path,
        attrs: dict[str, Any],
        *,
        resume: bool = False,
        overwrite: bool = False,
        log: Callable[[str], None] = lambda s: None,
    ) -> RunReport:
        path = Path(path)
        key = run_key(self.graph, self.options)
        n_beams = self.local.plan.beam_count
        starts = [b for b in chunks(n_beams, self.options.chunk_beams)]
        done = np.zeros(len(starts), bool)
        state = run_state(path) if path.exists() else None
        if path.exists():
            if overwrite:
                shutil.rmtree(path)
                state = None
            elif not resume:
                raise StoreExistsError(
                    f"{path} exists; pass --resume to complete it or --overwrite to replace it"
                )
            elif state is None:
                # Killed while the template was being written: nothing of value is there.
                shutil.rmtree(path)
            elif state[0].get("pasim_run_key") != key:
                raise ResumeError(
                    f"{path} was written by another run (graph, seed, chunk "
                    "size or products differ); use --overwrite to replace it"
                )
            else:
                done = state[1].astype(bool)
                if state[0].get(COMPLETE) == "true":
                    log(f"{path} is already complete")
                    return RunReport(len(starts), 0, n_beams)
        attrs = {**attrs, "pasim_run_key": key, "chunk_beams": self.options.chunk_beams}

        t0 = time.perf_counter()
        # A cluster takes seconds to start; it starts while the inputs are read.
        pool = ThreadPoolExecutor(1)
        client = pool.submit(self._connect) if (self.workers or self.scheduler) else None
        try:
            self.local.load()
            static = self.local.run_static()
            if state is None:
                # One beam fixes the store's layout; every chunk then runs in parallel.
                parts = self.local.run_chunk(static, np.arange(1))
                first = merge_products(parts + self.local.static_products(static))
                root, sweep = split_volume(first, attrs)
                create_volume(
                    path,
                    root,
                    sweep,
                    self._all_beam_coords(static, sweep),
                    n_beams,
                    self.options.chunk_beams,
                    len(starts),
                )
            todo = [i for i in range(len(starts)) if not done[i]]
            # Blocks that run once have done their I/O; workers need only per-chunk blocks.
            plan = self.local.plan
            plan.resources = {n: r for n, r in plan.resources.items() if n in plan.per_chunk}
            t1 = time.perf_counter()
            if client is not None:
                self._compute_distributed(client.result(), todo, starts, static, str(path), attrs)
            else:
                self._compute_threads(todo, starts, static, str(path), attrs)
            t2 = time.perf_counter()
        finally:
            if client is not None:
                # The cluster may have failed to start; then there is nothing to close.
                connected = None if client.exception() else client.result()
                if connected is not None:
                    connected.close()
                if self._cluster is not None:
                    self._cluster.close()
            pool.shutdown()
        mark_complete(path)
        return RunReport(len(starts), len(todo), n_beams, t1 - t0, t2 - t1)

    def _all_beam_coords(self, static: dict, sweep: xr.Dataset) -> dict[str, Any]:
        """Index coordinates along the beams, for every beam (the template needs them all)."""
        plan = self.local.plan
        source = next(n for n in plan.per_chunk if plan.graph.classes[n].beam_source)
        values = dict(static)
        self.local._run_block(source, values, np.arange(plan.beam_count))
        beams = next(v for (b, _), v in values.items() if b == source)
        _, full = split_volume(beams, {})
        dim = beam_dimension(full)
        return {
            str(name): full[name].variable
            for name in full.coords
            if dim in full[name].dims and name in sweep.coords
        }

    def _compute_threads(
        self,
        todo: list[int],
        starts: list[np.ndarray],
        static: dict,
        path: str,
        attrs: dict[str, Any],
    ) -> None:
        import dask
        from dask.diagnostics import ProgressBar
        from threadpoolctl import threadpool_limits

        tasks = [
            dask.delayed(_run_and_write, pure=False)(self.local, static, starts[i], i, path, attrs)
            for i in todo
        ]
        # Chunks already fill every core; BLAS threads inside each would oversubscribe them
        # and spin (a tenfold slowdown of small matrix products was measured). Dask's
        # distributed workers get the same limit from their nanny's environment.
        with (
            threadpool_limits(limits=1, user_api="blas"),
            ProgressBar() if self.progress else contextlib.nullcontext(),
        ):
            dask.compute(*tasks, scheduler="threads")

    def _connect(self) -> Any:
        from distributed import Client, LocalCluster

        if self.scheduler:
            client = Client(self.scheduler)
        else:
            import dask

            # Dask's nannies give their workers MALLOC_TRIM_THRESHOLD_, which turns off glibc's
            # adaptive mmap threshold: every large numpy temporary becomes a fresh mmap of
            # zeroed pages. Measured on the generic radar: chunks 1.5x slower. Memory stays
            # bounded by the chunk without it.
            trim = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"
            with dask.config.set({trim: None}):
                self._cluster = LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                )
            client = Client(self._cluster)
        # Workers import the block modules (and their numerical libraries) now, while this
        # process is still reading the inputs, not when their first chunk arrives.
        client.run(_warm_up, [self.graph.classes[n] for n in self.local.plan.per_chunk])
        return client

    def _compute_distributed(
        self,
        client: Any,
        todo: list[int],
        starts: list[np.ndarray],
        static: dict,
        path: str,
        attrs: dict[str, Any],
    ) -> None:
        from distributed import progress, wait

        if not todo:
            return
        local = client.scatter(self.local, broadcast=True)
        shared = client.scatter(static, broadcast=True)
        futures = [
            client.submit(_run_and_write, local, shared, starts[i], i, path, attrs, pure=False)
            for i in todo
        ]
        if self.progress:
            progress(futures)
        wait(futures)
        for f in futures:
            f.result()  # re-raise a failed chunk's error here
