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

import errno
import json
import math
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .block import Block
from .chunk_tasks import chunk_key, compute_distributed, compute_local
from .cluster import (
    LOCAL_SCHEDULERS,
    check_storage,
    open_client,
    warm_up_workers,
)
from .executor import RunOptions, chunks, merge_products
from .fm301 import sweep_group
from .graph import Graph
from .interrupt import STOPPING, Stopped, signals_held
from .resources import (
    DiskFullError,
    Probe,
    ResourceError,
    check_resources,
    chunks_at_once,
    disk_full_message,
    layout_bytes,
    stored_bytes,
    traced,
)
from .scores import TIME_ON_TARGET, time_on_target
from .store import (
    COMPLETE,
    DONE,
    RelayError,
    ResumeError,
    StoreLock,
    SweepLayout,
    beam_dimension,
    clear_store,
    damaged_chunks,
    describe_holder,
    discard_store,
    input_digests,
    lay_out,
    mark_complete,
    mark_incomplete,
    missing_arrays,
    open_store,
    relay_missing,
    replace_store,
    resume_mismatch,
    run_key,
    run_state,
    some,
    split_volume,
    sweep_template,
    volume_sweeps,
)
from .sweep_stage import run_stored_stage, stage_arrays, stage_done
from .sweeps import sweep_executors
from .task_record import TaskRecord

__all__ = ["ResourceError", "ResumeError"]  # re-exported: the command line catches them here


@dataclass
class RunReport:
    chunks_total: int
    chunks_run: int
    beams: int
    seconds_setup: float = 0.0  # inputs, once-per-run blocks, the layout, starting the cluster
    seconds_chunks: float = 0.0  # running and writing the chunks
    sweeps: int = 1
    time_on_target_s: float = 0.0  # sum of the dwells of every beam of every sweep


#: The most beams a chunk is given when the run does not say (``--chunk``): the size whose
#: memory docs/performance.md measures.
MOST_BEAMS = 8

#: Held by a run sharing a client with others (a study's runs in flight) while it sets up in
#: this process (truth, once-per-run blocks, first beam, layout), so that set-ups go one at a
#: time, each whole: in one interpreter, N set-ups at once share it and all end when the last
#: does, N times later than the first would have, while the cluster waits for chunks (17 runs
#: in flight on 16 workers); one at a time, the first run's chunks start after its own
#: set-up and the others follow.
SETTING_UP = threading.Lock()


def choose_chunk(n_beams: int, slots: int, most: int = MOST_BEAMS, overhead: float = 1.0) -> int:
    """Beams per chunk for a run of ``n_beams`` on ``slots`` chunks at once (workers).

    The chunk, at most ``most`` beams, whose chunks, handed in scan order to whichever slot is
    free first, end soonest, each costing its beams plus a task's fixed cost (``overhead``, in
    beams: writing the region and its flag, the scheduler; about one beam of the generic
    radar, from the task record). Ties go to the larger chunk (fewer tasks, fewer files).
    180 beams on 16 workers: 30 chunks of 6 end after 14 beams' time, 23 chunks of 8 after 18.
    """
    import heapq

    slots = max(1, int(slots))
    best, cost = most, math.inf
    for size in range(max(1, min(most, n_beams)), 0, -1):
        free = [0.0] * min(slots, math.ceil(n_beams / size))
        for start in range(0, n_beams, size):
            heapq.heappush(free, heapq.heappop(free) + min(size, n_beams - start) + overhead)
        if max(free) < cost - 1e-9:
            best, cost = size, max(free)
    return best


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
    client : distributed.Client, optional
        A client to run on instead of one of the run's own (a study's runs share one, made
        by :func:`open_client`): the run neither closes it nor warms its workers up (whoever
        made it does, once: :func:`warm_up_workers`). ``scheduler`` then only names it in
        the task record and messages.
    """

    def __init__(
        self,
        graph: Graph,
        options: RunOptions | None = None,
        *,
        workers: int | None = None,
        scheduler: str | None = None,
        progress: bool = False,
        chunk_auto: bool = False,
        client: Any = None,
    ):
        self.graph = graph
        self.options = options or RunOptions()
        #: One executor per sweep of the scan (most scans have one); they share all but the
        #: beam source. ``local`` is the first.
        self.sweeps = sweep_executors(graph, self.options)
        self.local = self.sweeps[0]
        n_beams = max(s.plan.beam_count for s in self.sweeps)
        #: The chunk size was chosen here (``choose_chunk``), not asked for: a resumed store
        #: keeps the chunking it was begun with.
        self.chunk_auto = chunk_auto
        if chunk_auto:
            total = sum(s.plan.beam_count for s in self.sweeps)
            slots = chunks_at_once(workers, scheduler, LOCAL_SCHEDULERS) or 1
            self._set_chunk(choose_chunk(total, slots))
        if self.options.chunk_beams > n_beams:
            # One chunk holds the whole scan: a larger chunk changes nothing but the store's
            # chunk shape, which zarr and dask cannot make of an --chunk of 2**64.
            self.options = replace(self.options, chunk_beams=n_beams)
            for sweep in self.sweeps:
                sweep.options = self.options
        self.workers, self.scheduler, self.progress = workers, scheduler, progress
        self._cluster: Any = None
        self._client = client  # given: shared with other runs, never closed here
        self._disk_estimate = 0  # bytes the store will take, once the first beam has shown it
        self._stage_redo: set[int] = set()  # sweeps whose stage must run again (arrays gone)

    def worker_classes(self) -> list[type[Block]]:
        """The block classes whose code runs on the workers (the per-chunk blocks)."""
        return [self.graph.classes[n] for n in self.local.plan.per_chunk]

    def _set_chunk(self, chunk_beams: int) -> None:
        self.options = replace(self.options, chunk_beams=chunk_beams)
        for sweep in self.sweeps:
            sweep.options = self.options

    def adopt_chunking(self, path: Path) -> None:
        """With a chunk size chosen here, resume a store in the chunking it was begun with."""
        from .store import is_store

        if not (self.chunk_auto and path.is_dir() and is_store(path)):
            return
        state = run_state(path)
        stored = state[0].get("chunk_beams") if state is not None else None
        if isinstance(stored, int) and stored >= 1:
            self._set_chunk(stored)

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
        if self._client is None and self.scheduler not in (None, *LOCAL_SCHEDULERS):
            # Before the store is made: a worker that does not share its folder is refused.
            check_storage(self.scheduler, path.absolute().parent)
        if resume:
            self.adopt_chunking(path)
        inputs = input_digests(self.graph)
        key = run_key(self.graph, self.options, inputs)
        # Every chunk of every sweep, numbered in scan order: (sweep, beams).
        starts = [
            (k, b)
            for k, sweep in enumerate(self.sweeps)
            for b in chunks(sweep.plan.beam_count, self.options.chunk_beams)
        ]
        lock: StoreLock | None = None
        try:
            # A stop while the store is being taken (its lock file made, its marker written)
            # is raised here, once the lock is ``lock``, so the handlers below undo it.
            with signals_held():
                lock = open_store(path, overwrite=overwrite, resume=resume, command=command)
            if lock.previous:
                log(
                    "taking over the lock of a run that stopped early "
                    f"({describe_holder(lock.previous)})"
                )
            return self._run_locked(lock, key, inputs, starts, attrs, log)
        except OSError as exc:
            if lock is None:
                raise
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                discard_store(lock)
                raise
            discard_store(lock)  # only a store that holds nothing yet
            raise DiskFullError(disk_full_message(path, len(starts), self._disk_estimate)) from None
        except BaseException as exc:
            if lock is None:
                raise
            # Nothing computed was written yet: leave no empty store to trip the next run.
            discard_store(lock)
            # A store refused as another run's is left as it was found, lock file included.
            lock.release(restore=isinstance(exc, ResumeError))
            raise
        finally:
            if lock is not None:
                lock.release()

    def _run_locked(
        self,
        lock: StoreLock,
        key: str,
        inputs: dict[str, str],
        starts: list[tuple[int, np.ndarray]],
        attrs: dict[str, Any],
        log: Callable[[str], None],
    ) -> RunReport:
        path = lock.path.parent
        n_beams = sum(s.plan.beam_count for s in self.sweeps)
        done = np.zeros(len(starts), bool)
        # --overwrite: the old store is laid out afresh, but emptied only once this run has
        # read its inputs and passed its checks (lock.replace below).
        state = None if lock.replacing else run_state(path)
        missing: list[str] = []  # arrays the layout lists that are gone: laid out again
        kept: dict[str, Any] = {}  # the run's history, when its store is laid out again
        if state is not None and not lock.replacing:
            if state[0].get("pasim_run_key") != key:
                raise ResumeError(resume_mismatch(path, state[0], inputs))
            missing = missing_arrays(path)
            stage_missing = stage_arrays(self.local.plan, missing)
            if stage_missing:
                # A sweep-level block's array is gone: its stage runs again.
                log(f"writing again {len(stage_missing)} missing array(s) of {path}'s sweep stage")
                missing = [m for m in missing if m not in stage_missing]
                self._stage_redo = {int(m.split("/")[0].split("_")[1]) for m in stage_missing}
                mark_incomplete(path)
            if DONE in missing:
                # Which chunks were done is lost (a finished store's consolidated metadata
                # still names the flags): every chunk is run again, on a fresh layout.
                log(f"{path}: {DONE} is missing (the layout lists it); running every chunk")
                # The run resumed began when the store did: its history stays.
                kept = {k: state[0][k] for k in ("history",) if k in state[0]}
                state, missing = None, []
        if lock.replacing:
            pass
        elif state is None:
            # A new store, or one killed while its template was written: start afresh.
            clear_store(path)
        else:
            done = state[1].astype(bool)
            # In a finished store every chunk counts (a damaged done flag reads as not done);
            # in an unfinished one, chunks not yet done are written anyway.
            complete = state[0].get(COMPLETE) == "true"
            offsets: dict[str, tuple[int, int]] = {}
            for i, (k, _) in enumerate(starts):
                first, count = offsets.get(sweep_group(k), (i, 0))
                offsets[sweep_group(k)] = (first, count + 1)
            repair = [i for i in damaged_chunks(path, offsets) if complete or done[i]]
            if missing:
                log(
                    f"writing again {len(missing)} missing array(s) of {path} (the layout "
                    f"lists them): {some(missing, 6)}"
                )
                mark_incomplete(path)
            if repair:
                log(
                    f"rewriting {len(repair)} damaged chunk(s) of {path}: "
                    + ", ".join(f"{i} ({self._chunk_text(starts[i])})" for i in repair)
                )
                done[repair] = False
                mark_incomplete(path)
            elif complete and not missing and not self._stage_redo:
                log(f"{path} is already complete")
                return RunReport(len(starts), 0, n_beams, sweeps=len(self.sweeps))
        attrs = {
            **attrs,
            "pasim_run_key": key,
            "pasim_inputs": json.dumps(inputs, sort_keys=True),
            "chunk_beams": self.options.chunk_beams,
            **kept,
        }

        t0 = time.perf_counter()
        record = TaskRecord(self.workers, self.scheduler, self.options.chunk_beams)
        # A cluster takes seconds to start; it starts while the inputs are read. A client
        # given is ready, and its owner closes it.
        pool = ThreadPoolExecutor(1)
        distributed = self.workers or self.scheduler not in (None, *LOCAL_SCHEDULERS)
        client = None
        if self._client is not None:
            client = pool.submit(lambda: self._client)
        elif distributed:
            client = pool.submit(record.timed, "connect", self._connect)
        on_target = 0.0
        try:
            with SETTING_UP if self._client is not None else nullcontext():
                # The sweeps share their blocks' resources (one dict): read once.
                record.timed("load", self.local.load)
                static = record.timed("static", self.local.run_static)
                for sweep in self.sweeps:
                    sweep.check_steering(static, len(self.sweeps))
                if state is None:
                    on_target = record.timed(
                        "layout", self._lay_out, path, lock, static, attrs, len(starts)
                    )
                elif missing:
                    redo = self._lay_out_again(path, static, attrs, missing)
                    done[[i for i, (k, _) in enumerate(starts) if sweep_group(k) in redo]] = False
            todo = [i for i in range(len(starts)) if not done[i]]
            # Blocks that run once have done their I/O; workers need only per-chunk blocks.
            for sweep in self.sweeps:
                plan = sweep.plan
                keep = {*plan.per_chunk, *plan.sweep_level}
                plan.resources = {n: r for n, r in plan.resources.items() if n in keep}
            # Waiting for the cluster to start is set-up: the chunk phase begins when chunks
            # can run (before, a cluster slower to start than the layout was counted in it).
            connected = client.result() if client is not None else None
            t1 = time.perf_counter()
            if STOPPING.is_set():
                # A run in another thread than the one signals stop (a study's runs at once).
                raise Stopped(signal.SIGINT)
            keys = {i: chunk_key(key, path, i) for i in todo}
            compute = partial(compute_local, scheduler=self.scheduler, progress=self.progress)
            where = str(path)
            if connected is not None:
                compute = partial(
                    compute_distributed,
                    connected,
                    scheduler=self.scheduler,
                    progress=self.progress,
                )
                # Workers are given the store's absolute path: a relative one would be taken
                # from each worker's own working folder (another folder on another machine).
                where = str(path.absolute())
            tasks = record.timed(
                "chunks",
                compute,
                self.sweeps,
                todo,
                keys,
                starts,
                static,
                where,
                attrs,
                clock=time.process_time,
            )
            t2 = time.perf_counter()
            if STOPPING.is_set() or any(t is None for t in tasks):
                # Stopped in another thread than the one signals stop: the chunks that saw the
                # stop wrote nothing, and the store must not be marked complete.
                raise Stopped(signal.SIGINT)
            record.tasks += [t for t in tasks if t is not None]
            rewritten = {starts[i][0] for i in todo} | self._stage_redo
            self._run_stages(path, static, rewritten, record)
        finally:
            if client is not None and self._client is None:
                # The cluster may have failed to start; then there is nothing to close.
                connected = None if client.exception() else client.result()
                if connected is not None:
                    connected.close()
                if self._cluster is not None:
                    self._cluster.close()
            pool.shutdown()
        record.write(path)
        mark_complete(path)
        return RunReport(
            len(starts), len(todo), n_beams, t1 - t0, t2 - t1, len(self.sweeps), on_target
        )

    def _run_stages(self, path: Path, static: dict, rewritten: set[int], record: Any) -> None:
        """Each sweep's sweep-level blocks, once its chunks are all written: in a sweep whose
        stage has not finished, or one of whose chunks this run wrote (:mod:`.sweep_stage`)."""
        for k, sweep in enumerate(self.sweeps):
            group = sweep_group(k)
            if not sweep.plan.sweep_level:
                continue
            if k in rewritten or not stage_done(str(path), group):
                if STOPPING.is_set():
                    raise Stopped(signal.SIGINT)
                record.timed(
                    "sweep stage",
                    run_stored_stage,
                    sweep,
                    static,
                    str(path),
                    group,
                    self.options.chunk_beams,
                )

    def _lay_out(
        self, path: Path, lock: StoreLock, static: dict, attrs: dict[str, Any], n_chunks: int
    ) -> float:
        """Run each sweep's first beam, check the run fits, then write every sweep's layout
        and the root last. Returns the volume's time on target (s)."""
        layouts, probes, root = self._layouts(static, attrs)
        self._disk_estimate = check_resources(
            path,
            probes,
            lock,
            chunk_beams=self.options.chunk_beams,
            at_most=chunks_at_once(self.workers, self.scheduler, LOCAL_SCHEDULERS),
        )
        replace_store(lock)
        sweeps = [
            SweepLayout(sweep_group(k), sweep, coords, n, min(self.options.chunk_beams, n))
            for k, (sweep, coords, n) in enumerate(layouts)
        ]
        lay_out(path, sweeps, root, n_chunks)
        return float(root.attrs[TIME_ON_TARGET])

    def _lay_out_again(
        self, path: Path, static: dict, attrs: dict[str, Any], missing: list[str]
    ) -> set[str]:
        """Write again the ``missing`` arrays of the layout; returns the sweep groups whose
        chunks must be computed again (a missing array of theirs holds beams)."""
        layouts, _, root = self._layouts(static, attrs)
        templates = {
            sweep_group(k): sweep_template(sweep, coords, n, min(self.options.chunk_beams, n))
            for k, (sweep, coords, n) in enumerate(layouts)
        }
        try:
            return relay_missing(path, templates, root, missing)
        except RelayError as exc:
            raise ResumeError(str(exc)) from None

    def _layouts(
        self, static: dict, attrs: dict[str, Any]
    ) -> tuple[list[tuple[xr.Dataset, dict[str, Any], int]], list[tuple[Probe, int]], xr.Dataset]:
        """Each sweep's layout (its first beam's dataset, its beam coordinates, its number of
        beams), the probes of the first beams, and the root, from one beam per sweep."""
        # One beam per sweep fixes the store's layout; every chunk then runs in parallel. It
        # is also the probe that says whether the whole run fits.
        layouts, probes, times, roots = [], [], [], []
        for sweep_run in self.sweeps:
            parts, memory = traced(partial(sweep_run.run_chunk, static, np.arange(1)))
            first = merge_products(parts + sweep_run.static_products(static))
            root, sweep = split_volume(first, attrs)
            dim = beam_dimension(sweep)
            n = sweep_run.plan.beam_count
            geometry = sweep_run.beam_geometry(static)
            times.append(time_on_target(geometry))
            sweep.attrs[TIME_ON_TARGET] = times[-1]
            probe = Probe(*memory, stored_bytes(sweep, dim), layout_bytes(root, sweep, dim))
            probes.append((probe, n))
            layouts.append((sweep, self._all_beam_coords(geometry, sweep), n))
            roots.append(root)
        for k, (sweep, _, _) in enumerate(layouts):
            if len(layouts) > 1 and "sweep_number" in sweep:
                sweep["sweep_number"] = ((), k)
        root = roots[0]
        if "time_coverage_end" in roots[-1]:  # the volume ends with its last sweep
            root["time_coverage_end"] = roots[-1]["time_coverage_end"]
        root = root.assign(volume_sweeps([sweep for sweep, _, _ in layouts]))
        root.attrs[TIME_ON_TARGET] = float(sum(times))
        return layouts, probes, root

    def _chunk_text(self, start: tuple[int, np.ndarray]) -> str:
        k, beams = start
        where = f"sweep {k}, " if len(self.sweeps) > 1 else ""
        return f"{where}beams {beams[0]}-{beams[-1]}"

    def _all_beam_coords(self, geometry: xr.Dataset, sweep: xr.Dataset) -> dict[str, Any]:
        """Index coordinates along the beams, for every beam (the template needs them all);
        ``geometry`` is what the beam source gives for every beam of the sweep."""
        _, full = split_volume(geometry, {})
        dim = beam_dimension(full)
        return {
            str(name): full[name].variable
            for name in full.coords
            if dim in full[name].dims and name in sweep.coords
        }

    def _connect(self) -> Any:
        client, self._cluster = open_client(self.workers, self.scheduler)
        warm_up_workers(client, self.worker_classes())
        return client
