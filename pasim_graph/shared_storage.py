"""The check, before any chunk runs, that every worker of an external cluster shares the
store's folder with this process.

Workers write their chunks straight into the store, so ``--out`` must name the same folder
for this process and every worker (a shared file system, and the same path on each). A
relative ``--out`` is made absolute in this process (from its working folder) before the
check and before any chunk task is given it. A worker that sees another folder would write
its chunks where nobody reads them, or fail half way through the run.

:func:`check_shared_storage` proves it both ways with probe files: this process writes one
with a fresh token, each worker reads it back (it sees this process's writes) and writes one
of its own, which this process reads back (its writes reach this process). The probes are
removed whatever happens. A worker that fails is refused with one line naming it and the
folder, before the run writes anything.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Any

#: Probe files are hidden and named for the check (and the worker) that wrote them.
PREFIX = ".pasim-storage-probe-"


class StorageError(RuntimeError):
    """A worker cannot read or write the store's folder as this process sees it."""


def probe_folder(target: str | Path) -> Path:
    """The folder to probe for ``target``: itself or, where it is not made yet, the nearest
    of its parents that exists (the run makes the rest there)."""
    target = Path(target)
    for folder in (target, *target.parents):
        if folder.is_dir():
            return folder
    return Path(".")


def _worker_file(folder: str, token: str, address: str) -> Path:
    # The address names the worker; a file name holds none of its ":" or "/".
    safe = "".join(c if c.isalnum() else "_" for c in address)
    return Path(folder, f"{PREFIX}{token}-{safe}")


def probe_on_worker(folder: str, token: str, dask_worker: Any = None) -> str:
    """On a worker (``client.run`` gives ``dask_worker``): read this process's probe in
    ``folder`` and write one's own. Returns "" or what went wrong, in a few words."""
    address = dask_worker.address if dask_worker is not None else f"pid {os.getpid()}"
    try:
        seen = Path(folder, f"{PREFIX}{token}").read_text()
    except OSError as exc:
        return f"cannot read the probe the pasim process wrote there ({exc.strerror or exc})"
    if seen != token:
        return "reads another probe there than the pasim process wrote"
    mine = _worker_file(folder, token, address)
    try:
        mine.write_text(address)
        if mine.read_text() != address:
            return "cannot read back what it writes there"
    except OSError as exc:
        return f"cannot write there ({exc.strerror or exc})"
    return ""


def remove_on_worker(folder: str, token: str, dask_worker: Any = None) -> None:
    """On a worker: remove its probe, wherever it wrote it (this process may not see it)."""
    address = dask_worker.address if dask_worker is not None else f"pid {os.getpid()}"
    _worker_file(folder, token, address).unlink(missing_ok=True)


def check_shared_storage(client: Any, target: str | Path) -> None:
    """Refuse (:class:`StorageError`, one line naming the worker and the folder) a cluster
    one of whose workers does not share ``target``'s folder (:func:`probe_folder`) with this
    process. A relative ``target`` is taken from this process's working folder, as the
    chunk tasks are given it (:class:`~pasim_graph.dask_executor.DaskExecutor`)."""
    folder = probe_folder(Path(target).absolute())
    token = secrets.token_hex(8)
    ours = folder / f"{PREFIX}{token}"
    try:
        ours.write_text(token)
    except OSError as exc:
        raise StorageError(f"cannot write a probe in {folder}: {exc.strerror or exc}") from None
    problems: dict[str, str] = {}
    try:
        answers = client.run(probe_on_worker, str(folder), token)
        for address, problem in sorted(answers.items()):
            if not problem:
                mine = _worker_file(str(folder), token, address)
                try:
                    ok = mine.read_text() == address
                except OSError:
                    ok = False
                if not ok:
                    problem = "writes there where the pasim process does not see it"
            if problem:
                problems[address] = problem
    finally:
        ours.unlink(missing_ok=True)
        for file in folder.glob(f"{PREFIX}{token}-*"):
            file.unlink(missing_ok=True)
        try:
            client.run(remove_on_worker, str(folder), token)
        except Exception:
            pass  # a worker lost meanwhile: nothing of it to remove
    if problems:
        address, problem = next(iter(problems.items()))
        more = f" (and {len(problems) - 1} more worker(s))" if len(problems) > 1 else ""
        raise StorageError(
            f"worker {address}{more} does not share the store's folder {folder}: it "
            f"{problem}; every worker must read and write --out as this process does (a "
            f"shared file system, the same path on every machine)"
        )
