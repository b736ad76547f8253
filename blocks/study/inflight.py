"""Several runs of a study in flight at once on one cluster, their results taken in order.

A run spends seconds in the ``pasim`` process before its first chunk reaches a worker
(reading its truth, its once-per-run blocks, its first beam and layout) and, at its end,
waits for its last chunks while other workers have nothing to do. With several runs in
flight on one cluster, one run's set-up and tail overlap the other runs' chunks.

How many (:func:`runs_at_once`): one more than the cluster runs chunks at once (its workers'
threads), so that every worker can be busy with the runs in flight while one more sets up;
and a further run starts only while :data:`RUN_MEMORY` is available to this process (each
run in flight holds its inputs here, and a copy of them on every worker).

Each run runs in a thread of this process, on the study's one client (made, warmed up and
closed by the study in the calling thread, or with ``--scheduler`` by the command, which
checks the shared storage on it first: no run thread makes a client); everything else stays
in the calling thread and in the study's order (:func:`in_order`): building a run's graph,
recording the runs as they finish (the manifest, the antenna figures, the scores), so that
the study, its manifest and its report are those of the runs one after another.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Memory a run in flight may take in this process (its inputs, once-per-run blocks and
#: layout; docs/performance.md measures 390-870 MB for a whole run's process): a further run
#: starts only while this much is available.
RUN_MEMORY = 1 << 30


def runs_at_once(client: Any) -> int:
    """Runs in flight: one (in this thread) without a cluster (``client`` None), else the
    cluster's chunk slots (its workers' threads) plus one."""
    if client is None:
        return 1
    return max(1, sum(client.nthreads().values())) + 1


def in_order(
    items: Sequence[T],
    start: Callable[[T], Callable[[], R]],
    record: Callable[[T, R], None],
    limit: int,
    room: Callable[[], bool] = lambda: True,
) -> None:
    """Run ``start(item)()`` for every item, at most ``limit`` at once, and ``record`` each
    item's result in the items' order.

    ``start`` (building what the run needs) and ``record`` are called in this thread, in the
    items' order; only the callables ``start`` returns run in other threads. A further item
    is started only while ``room()`` says so (at least one is always in flight). With a
    limit of 1 every item runs in this thread, as a single run does (a signal interrupts it
    where it is). The first failure is raised once the items in flight have ended; items not
    begun are not started.
    """
    if limit <= 1:
        for item in items:
            record(item, start(item)())
        return
    pool = ThreadPoolExecutor(limit, thread_name_prefix="pasim-study-run")
    started: list[Future[R]] = []
    done = 0
    try:
        while done < len(items):
            running = [f for f in started[done:] if not f.done()]
            while len(started) < len(items) and len(running) < limit:
                if running and not room():
                    break
                future = pool.submit(start(items[len(started)]))
                started.append(future)
                running.append(future)
            failed = next((f for f in started if f.done() and f.exception() is not None), None)
            if failed is not None:
                failed.result()  # raises (the finally below waits for the others)
            if not started[done].done():
                wait(running, return_when=FIRST_COMPLETED)
                continue
            while done < len(started) and started[done].done():
                record(items[done], started[done].result())
                done += 1
    finally:
        # Runs not begun are dropped; those running end first (a stop reaches them through
        # pasim_graph.interrupt.STOPPING) so that the cluster outlives them.
        pool.shutdown(wait=True, cancel_futures=True)
