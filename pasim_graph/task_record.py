"""The record of a run's tasks kept with its store: when each set-up step and each chunk task
ran, where (worker, thread), its CPU time and the bytes it wrote. ``pasim_tasks`` in the root
attributes, one entry each time the store was run (a resume adds one); :func:`read_tasks`
reads it back. The executors write it; benchmarks and users read it (docs/scaling.md)."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: Root attribute of a store: the record of every run's tasks (JSON, one entry a run, a
#: resumed store holding one entry for each time it was run).
TASKS = "pasim_tasks"

#: A chunk task's fields in the record, in order (times in seconds from the run's start).
TASK_COLUMNS = (
    "kind",
    "index",
    "group",
    "beams",
    "start",
    "computed",
    "stop",
    "cpu_s",
    "process_cpu_s",
    "worker_cpu_s",
    "worker",
    "bytes",
)


class TaskRecord:
    """When each step of a run ran and where: the set-up steps in this process (reading the
    inputs, the once-per-run blocks, the layout, starting the cluster) and every chunk task
    on its worker. Kept with the store (root attribute ``pasim_tasks``) by :meth:`write`."""

    def __init__(self, workers: int | None, scheduler: str | None, chunk_beams: int):
        self.started = time.time()
        self.head = {
            "format": "pasim-tasks/1",
            "started": self.started,
            "workers": workers,
            "scheduler": scheduler or "threads",
            "chunk_beams": chunk_beams,
            "cores": os.cpu_count(),
        }
        self.steps: list[list[Any]] = []
        self.tasks: list[dict[str, Any]] = []

    def timed(
        self,
        kind: str,
        fn: Callable[..., Any],
        *args: Any,
        clock: Callable[[], float] = time.thread_time,
    ) -> Any:
        """Call ``fn(*args)`` in this process and record it as a step, with the CPU time of
        ``clock``: the calling thread's (a set-up step), or ``time.process_time`` for the
        chunk phase (``chunks``: every thread of this process, the scheduler's and the
        client's with a local cluster, the chunks themselves under dask's threads)."""
        start, cpu = time.time(), clock()
        try:
            return fn(*args)
        finally:
            self.steps.append([kind, self._t(start), self._t(time.time()), round(clock() - cpu, 4)])

    def _t(self, t: float) -> float:
        return round(t - self.started, 4)

    def entry(self) -> dict[str, Any]:
        rows = []
        for task in sorted(self.tasks, key=lambda t: t["index"]):
            row = dict(task)
            for k in ("start", "computed", "stop"):
                row[k] = self._t(row[k])
            for k in ("cpu_s", "process_cpu_s", "worker_cpu_s"):
                row[k] = round(row[k], 4)
            rows.append([row[c] for c in TASK_COLUMNS])
        return {
            **self.head,
            "stopped": self._t(time.time()),
            "steps": self.steps,
            "step_columns": ["kind", "start", "stop", "cpu_s"],
            "task_columns": list(TASK_COLUMNS),
            "tasks": rows,
        }

    def write(self, path: str | Path) -> None:
        """Append this run's entry to the store's record (before its completion marker)."""
        import zarr

        root = zarr.open_group(str(path), mode="r+")
        try:
            runs = json.loads(str(root.attrs.get(TASKS, "[]")))
        except ValueError:
            runs = []
        runs.append(self.entry())
        root.attrs[TASKS] = json.dumps(runs, separators=(",", ":"))


def read_tasks(path: str | Path) -> list[dict[str, Any]]:
    """A store's task record: one entry a run, each task a dict of :data:`TASK_COLUMNS`."""
    import zarr

    runs = json.loads(str(zarr.open_group(str(path), mode="r").attrs.get(TASKS, "[]")))
    for run in runs:
        run["tasks"] = [dict(zip(run["task_columns"], row, strict=True)) for row in run["tasks"]]
        run["steps"] = [dict(zip(run["step_columns"], row, strict=True)) for row in run["steps"]]
    return list(runs)
