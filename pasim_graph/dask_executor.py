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
import errno
import json
import os
import shutil
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .block import Block
from .executor import LocalExecutor, RunOptions, chunks, merge_products
from .graph import Graph
from .interrupt import STOPPING
from .resources import (
    DISK_MARGIN,
    THREAD_ADDRESS_SPACE,
    DiskFullError,
    Probe,
    ResourceError,
    address_space_limited,
    gib,
    layout_bytes,
    memory_available,
    stored_bytes,
    traced,
    tree_bytes,
)
from .resume_key import ResumeError, input_digests, resume_mismatch, run_key
from .store import (
    COMPLETE,
    DONE,
    StoreLock,
    beam_dimension,
    check_chunks,
    clear_store,
    create_volume,
    describe_holder,
    discard_store,
    mark_complete,
    mark_incomplete,
    open_store,
    replace_store,
    run_state,
    split_volume,
    write_region,
)


@dataclass
class RunReport:
    chunks_total: int
    chunks_run: int
    beams: int
    seconds_setup: float = 0.0  # reading inputs, once-per-run blocks, the store's layout
    seconds_chunks: float = 0.0  # running and writing the chunks


#: ``scheduler`` values that run in this process: dask's threads (the default) or its
#: synchronous scheduler (one chunk after another in the calling thread: pdb works, for
#: debugging). Anything else is the address of a ``dask.distributed`` scheduler.
LOCAL_SCHEDULERS = ("threads", "sync")


def chunk_key(run: str, index: int) -> str:
    """The Dask task key of one chunk: the same for the same run and chunk, every time."""
    return f"pasim-chunk-{run}-{index}"


def check_scheduler(address: str, timeout_s: float = 3.0) -> None:
    """Refuse quickly a scheduler address nothing answers at (dask would retry for 30 s)."""
    import socket
    from urllib.parse import urlsplit

    if address in LOCAL_SCHEDULERS:
        return
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme not in ("tcp", "tls"):
        raise SchedulerError(
            f"--scheduler {address!r}: expected tcp://HOST:PORT (or tls://), 'threads' or 'sync'"
        )
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host, port = None, None
    if not host or not port:
        raise SchedulerError(f"--scheduler {address!r}: expected tcp://HOST:PORT")
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except OSError as exc:
        raise SchedulerError(
            f"--scheduler {address!r}: no scheduler answers there "
            f"({exc.strerror or exc}, waited {timeout_s:g} s)"
        ) from None


class SchedulerError(RuntimeError):
    """The scheduler named for a run cannot be reached or understood."""


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
    if STOPPING.is_set():
        return -1
    _, sweep = split_volume(merge_products(executor.run_chunk(static, beams)), attrs)
    if STOPPING.is_set():
        return -1  # the run was stopped while this chunk ran: it writes nothing more
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
        ``"threads"`` (the default), ``"sync"`` (dask's synchronous scheduler, for
        debugging), or the address of an existing ``dask.distributed`` scheduler
        (``tcp://host:8786``).
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
        n_beams = self.local.plan.beam_count
        if self.options.chunk_beams > n_beams:
            # One chunk holds the whole scan: a larger chunk changes nothing but the store's
            # chunk shape, which zarr and dask cannot make of an --chunk of 2**64.
            self.options = replace(self.options, chunk_beams=n_beams)
            self.local.options = self.options
        self.workers, self.scheduler, self.progress = workers, scheduler, progress
        self._cluster: Any = None
        self._disk_estimate = 0  # bytes the store will take, once the first beam has shown it

    def run(
        self,
        path: str | Path,
        attrs: dict[str, Any],
        *,
        resume: bool = False,
        overwrite: bool = False,
        command: str = "",
        log: Callable[[str], None] = lambda s: None,
    ) -> RunReport:
        """Run every chunk not yet done and write it to the store at ``path``.

        The store is taken with :func:`~pasim_graph.store.open_store` (refusing what this
        program did not write, and stores another run is writing) and held locked until the
        run ends. ``command`` is recorded in the lock, so a refused run can say who holds it.
        """
        path = Path(path)
        inputs = input_digests(self.graph)
        key = run_key(self.graph, self.options, inputs)
        n_beams = self.local.plan.beam_count
        starts = [b for b in chunks(n_beams, self.options.chunk_beams)]
        lock = open_store(path, overwrite=overwrite, resume=resume, command=command)
        try:
            if lock.previous:
                log(
                    "taking over the lock of a run that stopped early "
                    f"({describe_holder(lock.previous)})"
                )
            return self._run_locked(lock, key, inputs, starts, attrs, log)
        except OSError as exc:
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                discard_store(lock)
                raise
            discard_store(lock)  # only a store that holds nothing yet
            raise DiskFullError(self._disk_full_message(path, len(starts))) from None
        except BaseException as exc:
            # Nothing computed was written yet: leave no empty store to trip the next run.
            discard_store(lock)
            # A store refused as another run's is left as it was found, lock file included.
            lock.release(restore=isinstance(exc, ResumeError))
            raise
        finally:
            lock.release()

    def _run_locked(
        self,
        lock: StoreLock,
        key: str,
        inputs: dict[str, str],
        starts: list[np.ndarray],
        attrs: dict[str, Any],
        log: Callable[[str], None],
    ) -> RunReport:
        path = lock.path.parent
        n_beams = self.local.plan.beam_count
        done = np.zeros(len(starts), bool)
        # --overwrite: the old store is laid out afresh, but emptied only once this run has
        # read its inputs and passed its checks (lock.replace below).
        state = None if lock.replacing else run_state(path)
        if lock.replacing:
            pass
        elif state is None:
            # A new store, or one killed while its template was written: start afresh.
            clear_store(path)
        elif state[0].get("pasim_run_key") != key:
            raise ResumeError(resume_mismatch(path, state[0], inputs))
        else:
            done = state[1].astype(bool)
            # In a finished store every chunk counts (a damaged done flag reads as not done);
            # in an unfinished one, chunks not yet done are written anyway.
            complete = state[0].get(COMPLETE) == "true"
            repair = [i for i in self._damaged_chunks(path, len(starts)) if complete or done[i]]
            if repair:
                log(
                    f"rewriting {len(repair)} damaged chunk(s) of {path}: "
                    + ", ".join(f"{i} (beams {starts[i][0]}-{starts[i][-1]})" for i in repair)
                )
                done[repair] = False
                mark_incomplete(path)
            elif state[0].get(COMPLETE) == "true":
                log(f"{path} is already complete")
                return RunReport(len(starts), 0, n_beams)
        attrs = {
            **attrs,
            "pasim_run_key": key,
            "pasim_inputs": json.dumps(inputs, sort_keys=True),
            "chunk_beams": self.options.chunk_beams,
        }

        t0 = time.perf_counter()
        # A cluster takes seconds to start; it starts while the inputs are read.
        pool = ThreadPoolExecutor(1)
        distributed = self.workers or self.scheduler not in (None, *LOCAL_SCHEDULERS)
        client = pool.submit(self._connect) if distributed else None
        try:
            self.local.load()
            static = self.local.run_static()
            if state is None:
                # One beam fixes the store's layout; every chunk then runs in parallel. It is
                # also the probe that says whether the whole run fits.
                parts, probe_memory = traced(lambda: self.local.run_chunk(static, np.arange(1)))
                first = merge_products(parts + self.local.static_products(static))
                root, sweep = split_volume(first, attrs)
                dim = beam_dimension(sweep)
                probe = Probe(
                    *probe_memory, stored_bytes(sweep, dim), layout_bytes(root, sweep, dim)
                )
                self._check_resources(path, probe, n_beams, lock)
                replace_store(lock)
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
            keys = {i: chunk_key(key, i) for i in todo}
            if client is not None:
                self._compute_distributed(
                    client.result(), todo, keys, starts, static, str(path), attrs
                )
            else:
                self._compute_local(todo, keys, starts, static, str(path), attrs)
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

    def _disk_full_message(self, path: Path, n_chunks: int) -> str:
        state = run_state(path) if path.exists() else None
        free = shutil.disk_usage(path if path.exists() else path.parent).free
        where = "while creating the store"
        if state is not None:
            where = f"with {int(state[1].sum())} of {n_chunks} chunks written"
        need = (
            f"; the whole run writes about {gib(self._disk_estimate)}"
            if self._disk_estimate
            else ""
        )
        keep = (
            "the store is kept: free space and complete it with --resume"
            if state is not None
            else "nothing was kept: free space and run it again"
        )
        return f"{path}: the disk is full ({where}; {gib(free)} free{need}); {keep}"

    def _damaged_chunks(self, path: Path, n_chunks: int) -> list[int]:
        """The run's chunks whose stored data was damaged on disk (to be written again).

        Damage outside the per-beam arrays (metadata, coordinates) cannot be rewritten chunk
        by chunk: that store is refused, naming it.
        """
        damage = check_chunks(path)
        redo, other = set(), []
        for d in damage:
            if d.chunk is not None and d.node == DONE:
                redo.add(d.chunk[0])
            elif d.chunk is not None and d.node.startswith("sweep_0/") and d.beam_axis is not None:
                redo.add(d.chunk[d.beam_axis])
            else:
                other.append(d)
        if other:
            raise ResumeError(
                f"{path}: " + "; ".join(map(str, other[:6])) + " cannot be rewritten by --resume "
                "(only whole chunks of the beams can); run it again with --overwrite"
            )
        return sorted(i for i in redo if i < n_chunks)

    def _check_resources(self, path: Path, probe: Probe, n_beams: int, lock: StoreLock) -> None:
        """Refuse a run whose products would not fit the disk, or whose chunks the memory."""
        disk = probe.stored_bytes * n_beams + probe.layout_bytes
        self._disk_estimate = disk
        free = shutil.disk_usage(path).free
        if lock.replacing:
            free += tree_bytes(path)  # the store being replaced is freed before writing
        # Beams compress differently (storm against clear air): the estimate was 0.74 to
        # 1.08 of what the example graphs wrote on the bundled scene (0.28 for the uniform
        # scene's sub-megabyte store; docs/reliability.md), so the run is refused unless a
        # half more than the estimate fits.
        if DISK_MARGIN * disk > free:
            raise ResourceError(
                f"this run would write about {gib(disk)} to {path} "
                f"({gib(probe.stored_bytes)} per beam x {n_beams} beams, compressed, plus "
                f"its layout; up to {DISK_MARGIN:g}x that in beams full of echo) and "
                f"{gib(free)} is free there; write fewer fields (--outputs, no --save-iq), "
                "fewer beams, or choose another --out"
            )
        if self.scheduler not in (None, *LOCAL_SCHEDULERS):
            return  # a remote cluster's memory is not ours to judge

        if self.workers:
            at_once = self.workers
        elif self.scheduler == "sync":
            at_once = 1
        else:
            at_once = os.cpu_count() or 1
        at_once = min(at_once, -(-n_beams // self.options.chunk_beams))
        beams = min(self.options.chunk_beams, n_beams)
        need = probe.shared_bytes + probe.working_bytes * beams * at_once
        threads = ""
        if address_space_limited() and at_once > 1:
            need += THREAD_ADDRESS_SPACE * at_once
            threads = f", plus {gib(THREAD_ADDRESS_SPACE * at_once)} of threads' address space"
        available = memory_available()
        if need > available:
            raise ResourceError(
                f"this run would need about {gib(need)} of memory ({gib(probe.working_bytes)} "
                f"per beam x {beams} beams per chunk x {at_once} chunks at once, plus "
                f"{gib(probe.shared_bytes)} shared{threads}) and {gib(available)} is available; "
                "use a smaller --chunk or fewer --workers"
            )

    def _all_beam_coords(self, static: dict, sweep: xr.Dataset) -> dict[str, Any]:
        """Index coordinates along the beams, for every beam (the template needs them all)."""
        _, full = split_volume(self.local.beam_geometry(static), {})
        dim = beam_dimension(full)
        return {
            str(name): full[name].variable
            for name in full.coords
            if dim in full[name].dims and name in sweep.coords
        }

    def _compute_local(
        self,
        todo: list[int],
        keys: dict[int, str],
        starts: list[np.ndarray],
        static: dict,
        path: str,
        attrs: dict[str, Any],
    ) -> None:
        import dask
        import dask.local
        import dask.threaded
        from dask.diagnostics import ProgressBar
        from threadpoolctl import threadpool_limits

        tasks = [
            dask.delayed(_run_and_write, pure=False)(
                self.local, static, starts[i], i, path, attrs, dask_key_name=keys[i]
            )
            for i in todo
        ]
        # Chunks already fill every core; BLAS threads inside each would oversubscribe them
        # and spin (a tenfold slowdown of small matrix products was measured). Dask's
        # distributed workers get the same limit from their nanny's environment.
        # Our own pool, so that a run that is stopped waits for the chunks already running
        # (they write nothing more) instead of leaving threads writing behind its back.
        pool = ThreadPoolExecutor(os.cpu_count() or 1) if self.scheduler != "sync" else None
        try:
            with (
                threadpool_limits(limits=1, user_api="blas"),
                ProgressBar() if self.progress else contextlib.nullcontext(),
            ):
                # The schedulers' functions, not their names: a name makes dask import
                # distributed to look for a client (half a second of every local run).
                if pool is None:
                    dask.compute(*tasks, scheduler=dask.local.get_sync)
                else:
                    dask.compute(*tasks, scheduler=dask.threaded.get, pool=pool)
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)

    def _connect(self) -> Any:
        import logging

        from distributed import Client, LocalCluster

        # distributed logs a lost connection as an ERROR with its traceback, on this
        # process's stderr; the run says what happened in one line of its own instead.
        for name in ["distributed", *logging.root.manager.loggerDict]:
            if name.startswith("distributed"):
                logging.getLogger(name).setLevel(logging.CRITICAL)

        if self.scheduler and self.scheduler not in LOCAL_SCHEDULERS:
            client = Client(self.scheduler, timeout="10s")
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
        keys: dict[int, str],
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
            client.submit(_run_and_write, local, shared, starts[i], i, path, attrs, key=keys[i])
            for i in todo
        ]
        from distributed.client import FuturesCancelledError
        from distributed.comm.core import CommClosedError

        try:
            if self.progress:
                progress(futures)
            wait(futures)
            for f in futures:
                f.result()  # re-raise a failed chunk's error here
        except (FuturesCancelledError, CommClosedError, TimeoutError) as exc:
            # The scheduler went away (or the client lost it): the chunks written so far are
            # kept and flagged; the rest are run by --resume, on this cluster or another.
            if client.status == "running" and not isinstance(exc, FuturesCancelledError):
                raise
            where = self.scheduler or "the local cluster"
            raise SchedulerError(
                f"lost the connection to the scheduler ({where}) during the run; the chunks "
                "written are kept: complete the store with --resume (any cluster, or none)"
            ) from None
