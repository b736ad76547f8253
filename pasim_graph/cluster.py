"""The Dask cluster a run or a study computes on: the scheduler's address checked before
anything starts, the check that its workers share the store's folder, the client and the
LocalCluster ``--workers`` starts, the workers' first-use costs paid as they start, and the
progress bar and worker names of the tasks it runs (:mod:`.dask_executor` describes the
tasks; this module is where they go)."""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .block import Block

#: ``scheduler`` values that run in this process: dask's threads (the default) or its
#: synchronous scheduler (one chunk after another in the calling thread: pdb works, for
#: debugging). Anything else is the address of a ``dask.distributed`` scheduler.
LOCAL_SCHEDULERS = ("threads", "sync")


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


def check_storage(scheduler: str, target: str | Path, client: Any = None) -> None:
    """Before anything is written: refuse (:class:`SchedulerError`, one line) the cluster at
    ``scheduler`` if one of its workers does not read and write ``target``'s folder as this
    process does (:mod:`pasim_graph.shared_storage`; a relative ``target`` is taken from this
    process's working folder, as the chunk tasks get it). ``client``: one already connected
    to it (a study's), used and left open; else one is made for the check and closed. A
    LocalCluster's workers (``--workers``) share this process's view."""
    from .shared_storage import StorageError, check_shared_storage

    own = client is None
    if own:
        try:
            client, _ = open_client(None, scheduler)
        except OSError as exc:  # distributed's TimeoutError is one
            raise SchedulerError(f"--scheduler {scheduler!r}: cannot connect ({exc})") from None
    try:
        check_shared_storage(client, target)
    except StorageError as exc:
        raise SchedulerError(str(exc)) from None
    finally:
        if own:
            client.close()


def warm_up_here(classes: list[type[Block]]) -> None:
    """A worker's first-use costs, paid when it starts (while the client reads the inputs)
    instead of in its first chunk: the blocks' lazy imports, and the engine's own."""
    for cls in classes:
        cls.warm_up()
    warm_engine()


def warm_engine() -> None:
    """Pay the first use of what every chunk task uses: xarray's look-up of the duck-array
    libraries (it imports pint, sparse, cupy... at the first index it builds: 0.5-1 s of CPU,
    measured in a worker's first chunk) and the store's write path (xarray's zarr backend, the
    codecs), on a throwaway store in a temporary folder; the stored attributes' table (read
    once, its check of xradar's version imports ``importlib_metadata``); a variable's size
    (xarray imports its array-API module at the first)."""
    import tempfile

    from .fm301 import cf_attributes
    from .store import encoding

    cf_attributes()

    ds = xr.Dataset(
        {"v": (("azimuth", "range"), np.zeros((2, 3), np.float32))},
        coords={"azimuth": np.arange(2.0), "range": np.arange(3.0)},
    )
    ds = xr.merge([ds, ds.rename({"v": "w"})], compat="override", join="override")
    ds["v"].nbytes  # noqa: B018  (its first use imports)
    with tempfile.TemporaryDirectory(prefix="pasim-warm-") as tmp:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds.to_zarr(tmp, mode="w", encoding={"v": encoding(np.dtype(np.float32))})
            ds[["v"]].drop_vars(["azimuth", "range"]).to_zarr(
                tmp, region={"azimuth": slice(0, 2)}, consolidated=False
            )


#: What a LocalCluster started here does not run: the workers' statistical profiler (a
#: stack sample every 10 ms, for a dashboard this cluster does not serve) and the event-loop
#: ticks, system monitors and memory checks at dashboard rates. On the 2-core machine, with
#: both cores computing chunks, these took 1.1-1.3 s of CPU a worker and 1.6 s in this process
#: over a 15 s chunk phase (per-thread ``schedstat``): time the chunk threads spent waiting
#: for a core. The workers still report their memory, and the nannies still restart a
#: worker over its limit, every half second.
QUIET_CLUSTER = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "500ms",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "500ms",
}


def open_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """A ``dask.distributed`` client and the LocalCluster it runs on (None for a
    ``scheduler`` address): ``workers`` single-threaded worker processes started here, or
    the scheduler at ``scheduler``. The caller closes both."""
    import logging

    from distributed import Client, LocalCluster

    # distributed logs a lost connection as an ERROR with its traceback, on this
    # process's stderr; the run says what happened in one line of its own instead.
    for name in ["distributed", *logging.root.manager.loggerDict]:
        if name.startswith("distributed"):
            logging.getLogger(name).setLevel(logging.CRITICAL)

    if scheduler and scheduler not in LOCAL_SCHEDULERS:
        return Client(scheduler, timeout="10s"), None
    import dask

    # Dask's nannies give their workers MALLOC_TRIM_THRESHOLD_, which turns off glibc's
    # adaptive mmap threshold: every large numpy temporary becomes a fresh mmap of zeroed
    # pages. Measured on the generic radar: chunks 1.5x slower. Memory stays bounded by
    # the chunk without it.
    trim = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"
    with dask.config.set({trim: None, **QUIET_CLUSTER}):
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        )
    try:
        client = Client(cluster)
        from .worker_exit import FreezeAtClose

        client.register_plugin(FreezeAtClose())
        return client, cluster
    except BaseException:
        cluster.close()
        raise


def close(client: Any, cluster: Any = None) -> None:
    """Close ``client`` and then the LocalCluster it runs on (either may be None)."""
    if client is not None:
        client.close()
    if cluster is not None:
        cluster.close()


def workers_in_range(workers: int, cores: int | None) -> bool:
    """Whether ``--workers`` asks for 1 to ``cores`` local workers (any number when the
    cores are not known)."""
    return workers >= 1 and (not cores or workers <= cores)


class StartingCluster:
    """A LocalCluster of ``workers`` started in a thread of its own (:func:`open_client`)
    while the caller goes on (a study sizes and plans its runs: its workers start, import
    and register meanwhile). :meth:`take` waits for it and hands it over; :meth:`drop` closes
    one never taken (the study refused, stopped or broken first)."""

    def __init__(self, workers: int):
        from concurrent.futures import ThreadPoolExecutor

        # The cluster's modules imported here (0.16 s), not in the thread: two threads
        # importing the same packages at once can meet each other's half-initialised ones.
        import distributed  # noqa: F401

        from . import worker_exit  # noqa: F401

        self._pool = ThreadPoolExecutor(1, thread_name_prefix="pasim-cluster-start")
        self._started = self._pool.submit(open_client, workers, None)
        self._pool.shutdown(wait=False)
        self._taken = False

    def take(self) -> tuple[Any, Any]:
        """The client and its cluster (the caller closes both); a failed start raises here."""
        self._taken = True
        return self._started.result()

    def drop(self) -> None:
        if self._taken:
            return
        self._taken = True
        try:
            client, cluster = self._started.result()
        except Exception:  # a start that failed has nothing to close
            return
        close(client, cluster)


def warm_up_workers(client: Any, classes: list[type[Block]], *, wait: bool = True) -> None:
    """Workers import the block modules (and their numerical libraries) now, while this
    process is still reading the inputs, not when their first chunk arrives. ``wait=False``
    only sends it, from a thread of its own (the calling thread goes on reading inputs; a
    chunk that reaches a worker first pays the imports itself, as without a warm-up)."""
    if wait:
        client.run(warm_up_here, classes)
        return
    threading.Thread(
        target=_send_warm_up, args=(client, classes), name="pasim-warm-up", daemon=True
    ).start()


def _send_warm_up(client: Any, classes: list[type[Block]]) -> None:
    # distributed sends without waiting only a coroutine function (it runs it on the
    # worker's event loop, as it runs a plain one). The scheduler sends it to every worker
    # it knows: one just lost (a study's worker killed) it tries to reach for 30 s, then the
    # call fails. Sent from the calling thread, that stalled a study's next run 30 s and then
    # ended the study; a warm-up is only ahead of time, and whatever keeps it from a worker
    # (lost, or the client closed as the study ends) leaves that worker's first chunk to pay
    # the imports.
    with contextlib.suppress(Exception):
        client.run(_warm_up_async, classes, wait=False)


async def _warm_up_async(classes: list[type[Block]]) -> None:
    warm_up_here(classes)


def worker_name() -> str:
    """Where a task ran: host, process and (under dask's threads) thread."""
    import socket
    import threading

    thread = threading.current_thread()
    where = f"{socket.gethostname()}:{os.getpid()}"
    return where if thread is threading.main_thread() else f"{where}/{thread.name}"


def progress_bar(client: Any, futures: list[Any]) -> Any:
    """distributed's text progress bar for ``futures``, drawn from a thread of its own (it
    blocks until they end) on standard error: standard output holds the product (the score
    table)."""
    import threading

    from distributed import progress

    def draw() -> None:
        with contextlib.suppress(Exception), contextlib.redirect_stdout(sys.stderr):
            progress(futures, scheduler=client.scheduler.address)

    thread = threading.Thread(target=draw, name="pasim-progress", daemon=True)
    thread.start()
    return thread
