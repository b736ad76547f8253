"""The study's antenna and hardware measurements, beside its runs.

Each system's pattern figures (:mod:`.patterns`) and hardware (:mod:`.hardware`) are measured
once: seconds of computing per system (the 10 m CPPAR's antenna 3.3 s). Without a cluster they
are measured in the calling thread once the system's first estimate has finished. With a
cluster they are tasks on it instead, sent as that estimate starts (``runner.measure_ahead``),
in parallel with each other and with the runs' chunks (a task without a priority goes before
the chunks: a measurement is on the study's critical path, a chunk is one of many); their
results are kept in the manifest as they come, and every one is in before the study's runs
are reported done. The functions are pure, seeded by the run: the same figures either way.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

#: The manifest's list of the measurement tasks' records (:func:`recorded`), in the order
#: they were kept.
MEASUREMENTS = "measurements"


class Measuring:
    """Measurements started here or on ``client``'s cluster, kept in ``state[part][key]``."""

    def __init__(self, state: dict[str, Any], keep: Callable[[], None], log: Callable[[str], None]):
        self.state, self.keep, self.log = state, keep, log
        self.client: Any = None
        # (part, key) -> (future, what), for those on the cluster
        self._flight: dict[tuple[str, str], tuple[Any, str]] = {}

    def wanted(self, part: str, key: str) -> bool:
        """Neither measured nor being measured."""
        return key not in self.state.setdefault(part, {}) and (part, key) not in self._flight

    def start(
        self, part: str, key: str, what: str, measure: Callable[..., dict], *args: Any
    ) -> None:
        """Measure ``measure(*args)`` into ``state[part][key]``: now, or as a cluster task
        (``what`` names it in the log line)."""
        if self.client is None:
            self._done(part, key, what, *recorded(measure, *args))
            return
        # A key of this study's own (another study on the cluster may measure the same names).
        token = os.urandom(6).hex()
        future = self.client.submit(
            recorded, measure, *args, key=f"pasim-measure-{part}-{key}-{token}"
        )
        self._flight[(part, key)] = (future, what)

    def gather(self, wait: bool = False) -> None:
        """Keep the measurements that have ended (with ``wait``, every one: a failure is
        raised here, as it would have been in the calling thread)."""
        for (part, key), (future, what) in list(self._flight.items()):
            if wait or future.done():
                value, record = future.result()
                del self._flight[(part, key)]
                self._done(part, key, what, value, record)

    def drop(self) -> None:
        """Forget the measurements in flight (the study stops: a resume measures them)."""
        for future, _ in self._flight.values():
            future.release()
        self._flight.clear()

    def _done(self, part: str, key: str, what: str, value: dict, record: dict) -> None:
        self.state.setdefault(part, {})[key] = value
        # The study's record of its measurement tasks, beside its runs' (each store's
        # ``pasim_tasks``): where and when each ran, its CPU (docs/scaling.md).
        self.state.setdefault(MEASUREMENTS, []).append({"kind": part, "key": key, **record})
        self.keep()
        self.log(f"measured {what}: {record['stop'] - record['start']:.1f} s")


def recorded(work: Callable[..., T], *args: Any) -> tuple[T, dict[str, Any]]:
    """``work(*args)`` and its record where it ran: its start and stop (epoch seconds), its
    thread's CPU seconds, its process's CPU seconds before it (a worker's start-up and what
    it ran before) and the worker (:func:`pasim_graph.cluster.worker_name`)."""
    from pasim_graph.cluster import worker_name

    start, cpu, process_cpu = time.time(), time.thread_time(), time.process_time()
    value = work(*args)
    return value, {
        "start": round(start, 4),
        "stop": round(time.time(), 4),
        "cpu_s": round(time.thread_time() - cpu, 4),
        "worker_cpu_s": round(process_cpu, 4),
        "worker": worker_name(),
    }


def timed(work: Callable[..., T], *args: Any) -> tuple[T, float]:
    """``work(*args)`` and the seconds it took where it ran (not counting its wait in the
    cluster's queue, nor the study's wait for it)."""
    t0 = time.perf_counter()
    return work(*args), time.perf_counter() - t0
