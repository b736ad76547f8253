"""A run's chunk tasks and where they run: each task runs the graph on one chunk of one
sweep's beams and writes that region of the store (on a worker, or a thread of this process);
:func:`compute_local` hands them to dask's threads here, :func:`compute_distributed` to a
``dask.distributed`` cluster, with the run's shared inputs sent once. :mod:`.dask_executor`
decides which chunks run and what happens before and after them."""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from .cluster import SchedulerError, progress_bar, worker_name
from .executor import LocalExecutor, merge_products
from .fm301 import sweep_group
from .interrupt import STOPPING
from .store import beam_dimension, split_volume, write_region


def chunk_key(run: str, path: str | Path, index: int) -> str:
    """The Dask task key of one chunk: the same for the same run, store and chunk, every time.

    The store is part of it: a cluster runs a key once, for whoever asks first, so two runs
    of one run key (a study's reference runs that several points share) in flight at once
    into two stores would otherwise both be given the chunks written into the first one."""
    where = hashlib.sha256(str(Path(path).resolve()).encode()).hexdigest()[:12]
    return f"pasim-chunk-{run}-{where}-{index}"


def run_and_write(
    executor: LocalExecutor,
    static: dict,
    beams: np.ndarray,
    index: int,
    path: str,
    attrs: dict[str, Any],
    group: str = "sweep_0",
    run: str | None = None,
) -> dict[str, Any] | None:
    """One task: run the graph on a chunk of one sweep's beams and write its region of that
    sweep's group (on a worker); ``index`` numbers the chunk among all the run's chunks,
    ``run`` this run of the store's layout (:func:`.store.write_region`).

    Returns the task's record (when it ran, where, its CPU time and the bytes it wrote), or
    None when the run was stopped before it wrote.
    """
    if STOPPING.is_set():
        return None
    start, cpu, process_cpu = time.time(), time.thread_time(), time.process_time()
    _, sweep = split_volume(merge_products(executor.run_chunk(static, beams)), attrs)
    computed = time.time()
    if STOPPING.is_set():
        return None  # the run was stopped while this chunk ran: it writes nothing more
    write_region(path, sweep, int(beams[0]), index, group, run)
    beam_dim = beam_dimension(sweep)
    return {
        "kind": "chunk",
        "index": index,
        "group": group,
        "beams": [int(beams[0]), int(beams[-1]) + 1],
        "start": start,
        "computed": computed,
        "stop": time.time(),
        "cpu_s": time.thread_time() - cpu,
        "process_cpu_s": time.process_time() - process_cpu,
        "worker_cpu_s": process_cpu,
        "worker": worker_name(),
        "bytes": int(sum(v.nbytes for v in sweep.data_vars.values() if beam_dim in v.dims)),
    }


def compute_local(
    sweeps: list[LocalExecutor],
    todo: list[int],
    keys: dict[int, str],
    starts: list[tuple[int, np.ndarray]],
    static: dict,
    path: str,
    attrs: dict[str, Any],
    *,
    scheduler: str | None,
    progress: bool,
) -> list[dict[str, Any] | None]:
    """Run the chunks ``todo`` on dask's threads in this process (``scheduler`` "sync": one
    after another in the calling thread); their records, in the order of ``todo``."""
    import dask
    import dask.local
    import dask.threaded
    from dask.diagnostics import ProgressBar
    from threadpoolctl import threadpool_limits

    run = os.urandom(8).hex()  # the store's arrays are opened once for this run's chunks
    tasks = [
        dask.delayed(run_and_write, pure=False)(
            sweeps[starts[i][0]],
            static,
            starts[i][1],
            i,
            path,
            attrs,
            sweep_group(starts[i][0]),
            run,
            dask_key_name=keys[i],
        )
        for i in todo
    ]
    # Chunks already fill every core; BLAS threads inside each would oversubscribe them
    # and spin (a tenfold slowdown of small matrix products was measured). Dask's
    # distributed workers get the same limit from their nanny's environment.
    # Our own pool, so that a run that is stopped waits for the chunks already running
    # (they write nothing more) instead of leaving threads writing behind its back.
    pool = ThreadPoolExecutor(os.cpu_count() or 1) if scheduler != "sync" else None
    try:
        with (
            threadpool_limits(limits=1, user_api="blas"),
            ProgressBar(out=sys.stderr) if progress else contextlib.nullcontext(),
        ):
            # The schedulers' functions, not their names: a name makes dask import
            # distributed to look for a client (half a second of every local run).
            if pool is None:
                return list(dask.compute(*tasks, scheduler=dask.local.get_sync))
            return list(dask.compute(*tasks, scheduler=dask.threaded.get, pool=pool))
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


def neighbours_first(todo: list[int], streams: int) -> dict[int, int]:
    """The order (a rank from 0) in which a cluster running ``streams`` chunks at once should
    start the chunks ``todo``: cut into ``streams`` runs of neighbouring chunks, interleaved.

    The cluster gives a free slot the waiting chunk of highest priority. Without one, chunks
    submitted together tie and start in no particular order, so a worker's chunks are spread
    over the whole scan and every worker prepares nearly all of the truth near the beams
    (``TruthCells`` prepares it by blocks of radials, as beams reach them). Interleaved runs
    hand each slot, as long as the slots free up in turn, the chunk after its last one.
    """
    streams = stream_count(streams, len(todo))
    edges = np.linspace(0, len(todo), streams + 1).round().astype(int)
    return {
        i: j * streams + s
        for s in range(streams)
        for j, i in enumerate(todo[edges[s] : edges[s + 1]])
    }


def stream_count(slots: int, chunks: int) -> int:
    """How many runs of neighbours ``chunks`` chunks are cut into for ``slots`` slots (one at
    least, and none empty)."""
    return max(1, min(slots, chunks))


def pinned_to(rank: dict[int, int], slots: list[str], share: float = 0.75) -> dict[int, list[str]]:
    """The worker each chunk of the first ``share`` of every run of neighbours (``rank``, from
    :func:`neighbours_first` for ``len(slots)`` slots) is asked to run on: run ``s`` on
    ``slots[s]``. The rest is left to whichever worker is free (the runs' unequal costs are
    evened out there). No slots (a cluster whose workers have yet to join): none asked."""
    if not slots:
        return {}
    streams = stream_count(len(slots), len(rank))
    per = -(-len(rank) // streams)
    return {i: [slots[r % streams]] for i, r in rank.items() if r // streams < share * per}


def compute_distributed(
    client: Any,
    sweeps: list[LocalExecutor],
    todo: list[int],
    keys: dict[int, str],
    starts: list[tuple[int, np.ndarray]],
    static: dict,
    path: str,
    attrs: dict[str, Any],
    *,
    scheduler: str | None,
    progress: bool,
) -> list[dict[str, Any] | None]:
    """Run the chunks ``todo`` on the cluster of ``client``; their records, in the order of
    ``todo``. A failure is raised once every chunk has ended (none is left writing)."""
    from distributed import as_completed

    if not todo:
        return []
    used = sorted({starts[i][0] for i in todo})
    # The shared inputs (each sweep's executor, the once-per-run blocks' outputs) go as
    # tasks that return them (_given), not as scattered data: the scheduler keeps how to
    # make them, so the worker holding them may be lost (distributed's memory manager
    # keeps one copy of what the chunks still need) and they are made again on another.
    # Scattered data it cannot make again: a worker lost while it held the last copy
    # cancelled the chunks waiting for it ("lost dependencies"). Their keys are this
    # run's own (a fresh token: never another run's in flight on the same cluster); the
    # same token has each worker open the store's arrays once for the run's chunks.
    own = f"pasim-inputs-{os.urandom(8).hex()}"
    import dask

    # The inputs travel with their task through the scheduler: distributed warns above
    # 10 MB (a run's inputs are megabytes to a few hundred: docs/scaling.md).
    with dask.config.set({"distributed.admin.large-graph-warning-threshold": "64GiB"}):
        local = {
            k: client.submit(_given, _Box(sweeps[k].for_chunks()), key=f"{own}-sweep-{k}")
            for k in used
        }
        shared = client.submit(_given, _Box(static), key=f"{own}-static")
    # Each chunk's priority: a run submitted earlier first (as the scheduler would order
    # whole graphs, first come first served: a study's earlier runs finish first), and in a
    # run a free worker takes the chunk beside its last one (neighbours_first), its own
    # run's for the first three quarters of it even when another worker frees first
    # (pinned_to: loose, a lost or busy worker's chunks go elsewhere).
    slots = [w for w, n in sorted(client.nthreads().items()) for _ in range(n)]
    rank = neighbours_first(todo, len(slots))
    pinned = pinned_to(rank, slots)
    submitted = time.time_ns() // 1_000_000
    futures = [
        client.submit(
            run_and_write,
            local[starts[i][0]],
            shared,
            starts[i][1],
            i,
            path,
            attrs,
            sweep_group(starts[i][0]),
            own,
            key=keys[i],
            priority=-(submitted << 20) - min(rank[i], (1 << 20) - 1),
            **({"workers": pinned[i], "allow_other_workers": True} if i in pinned else {}),
        )
        for i in todo
    ]
    from distributed.client import FutureCancelledError, FuturesCancelledError
    from distributed.comm.core import CommClosedError

    index = {f.key: i for f, i in zip(futures, todo, strict=True)}
    records: dict[int, dict[str, Any] | None] = {}
    failed: dict[int, Any] = {}
    bar = progress_bar(client, futures) if progress else None
    try:
        # Each chunk's record is taken as it ends and the chunk released: a worker lost
        # afterwards holds nothing of it that the scheduler would run it again for (the
        # records of chunks done stayed on their workers until all were done: a worker
        # lost then re-ran its chunks already written). Every chunk ends before a failure
        # is raised: none is left writing behind the run's back.
        # The client's own loop: as_completed would take the latest client made in
        # this process (a study's runs share one; a test may watch with another).
        for future in as_completed(futures, loop=client.loop):
            i = index[future.key]
            if future.status == "finished":
                records[i] = future.result()
                future.release()
            else:
                failed[i] = future
        if failed:
            failed[min(failed)].result()  # raises the chunk's error (or its cancelling)
        return [records[i] for i in todo]
    except (
        FutureCancelledError,
        FuturesCancelledError,
        CommClosedError,
        TimeoutError,
        OSError,  # a record fetched as the scheduler goes away
    ) as exc:
        # The chunks written so far are kept and flagged; the rest are run by --resume,
        # on this cluster or another.
        cancelled = (FutureCancelledError, FuturesCancelledError)
        if not isinstance(exc, cancelled) and client.status == "running":
            # A chunk's own error (a full disk) is raised at once; a connection's only once
            # the client has had a moment to find its scheduler gone.
            connection = isinstance(exc, (CommClosedError, ConnectionError, TimeoutError))
            if not (connection and scheduler_lost(client)):
                raise
        where = scheduler or "the local cluster"
        if client.status == "running":
            # The scheduler is there and cancelled a chunk itself.
            reason = getattr(exc, "reason", None) or "unknown"
            raise SchedulerError(
                f"the scheduler ({where}) cancelled a chunk (reason: {reason}); the chunks "
                "written are kept: complete the store with --resume (any cluster, or none)"
            ) from None
        raise SchedulerError(
            f"lost the connection to the scheduler ({where}) during the run; the chunks "
            "written are kept: complete the store with --resume (any cluster, or none)"
        ) from None
    finally:
        if bar is not None:
            bar.join(timeout=1.0)


def scheduler_lost(client: Any, wait_s: float = 3.0) -> bool:
    """Whether ``client`` has lost its scheduler, given a moment to notice: a record fetched
    just as the scheduler is killed fails with the connection reset (CommClosedError) while
    the client still says "running" (seen once in CI: the run ended in a traceback instead of
    its one line); the client leaves "running" when it finds the scheduler gone."""
    deadline = time.monotonic() + wait_s
    while client.status == "running":
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)
    return True


class _Box:
    """What a run's shared inputs travel in to their task: opaque to dask (a dict's values
    are not looked into for keys and tasks)."""

    def __init__(self, value: Any):
        self.value = value


def _given(box: _Box) -> Any:
    """A task that makes a run's shared input: the value it was given (on a worker)."""
    return box.value
