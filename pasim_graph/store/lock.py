"""One writer per store: the lock file a run holds while it writes, and who holds it."""

from __future__ import annotations

import contextlib
import json
import time
from pathlib import Path
from typing import Any

from ..interrupt import signals_held

#: The lock file inside a store; its owner holds an flock on it.
LOCK = "pasim-run.lock"


class StoreError(RuntimeError):
    """A store cannot be written: not ours, in use by another run, or not writable."""


class StoreLock:
    """One writer per store: an flock held on ``LOCK`` inside the store while a run writes it.

    The lock file says who holds it (pid, host, start, command). The kernel releases an flock
    when its process dies, so a lock file left behind by a crash is free to take: that is how
    a stale lock is told from a live one, and ``--resume`` takes it over. Runs on other hosts
    cannot be checked that way; their locks are honoured until removed by hand.
    """

    def __init__(self, path: Path, fd: int, previous: dict[str, Any] | None):
        self.path, self._fd = path, fd
        #: What the lock file said when it was taken: the crashed run's details, or None.
        self.previous = previous
        #: The store was new when the run took it (or --overwrite has emptied it).
        self.fresh = False
        #: --overwrite of a finished store: its contents stay until the new run has read its
        #: inputs and passed its checks, then :func:`pasim_graph.store.replace_store` empties it.
        self.replacing = False
        #: The run made the store's directory.
        # Directories this run created for the store, deepest first (the store, then any
        # parents that were missing): a fresh run that fails removes them again.
        self.made_dirs: list[Path] = []
        self._previous_bytes = b""

    @classmethod
    def acquire(cls, store: Path, command: str) -> StoreLock:
        import fcntl
        import os
        import socket

        path = store / LOCK
        while True:
            try:
                fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                raise StoreError(f"{store}: cannot create {LOCK}: {exc.strerror or exc}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                # The holder writes who it is just after taking the lock: a run that lost a
                # race by microseconds waits for that, to name it.
                holder = _read_lock(fd)
                for _ in range(40):
                    if holder:
                        break
                    time.sleep(0.025)
                    holder = _read_lock(fd)
                os.close(fd)
                raise StoreError(
                    f"{store} is being written by another run ({describe_holder(holder)}); "
                    "wait for it to finish or choose another --out"
                ) from None
            # The previous owner may have deleted the file between our open and our flock:
            # then we hold a lock on a file nobody else can see, and must try again.
            try:
                same = os.fstat(fd).st_ino == os.stat(path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        previous_bytes = os.pread(fd, 65536, 0)
        previous = _read_lock(fd) or None
        host = socket.gethostname()
        if previous and previous.get("host") not in (None, host):
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
            raise StoreError(
                f"{store} is locked by a run on another host ({describe_holder(previous)}); "
                f"if that run is gone, delete {path}"
            )
        me = {
            "pid": os.getpid(),
            "host": host,
            "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "command": command,
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(me).encode(), 0)
        os.fsync(fd)
        lock = cls(path, fd, previous)
        lock._previous_bytes = previous_bytes
        return lock

    def release(self, restore: bool = False) -> None:
        """Remove the lock file and drop the lock (idempotent).

        With ``restore``, a lock file taken over from a run that stopped early is put back as
        it was instead (a refused command leaves the store as it found it).
        """
        import fcntl
        import os

        # A stop in the middle would leave the file behind: it is raised once this is done.
        with signals_held():
            if self._fd < 0:
                return
            if restore and self.previous:
                os.ftruncate(self._fd, 0)
                os.pwrite(self._fd, self._previous_bytes, 0)
            else:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.path)
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> StoreLock:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _read_lock(fd: int) -> dict[str, Any]:
    import os

    try:
        data = os.pread(fd, 65536, 0)
        out = json.loads(data) if data.strip() else {}
        return out if isinstance(out, dict) else {}
    except (OSError, ValueError):
        return {}


def current_writer(store: str | Path) -> dict[str, Any] | None:
    """Who is writing a store now (what its lock file says), or None when no run holds it."""
    import fcntl
    import os

    try:
        fd = os.open(Path(store) / LOCK, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return _read_lock(fd)  # held: a run is writing
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def describe_holder(holder: dict[str, Any]) -> str:
    """Who holds (or held) a store's lock, as the lock file says, in words."""
    if not holder:
        return "owner unknown"
    text = f"pid {holder.get('pid')} on {holder.get('host')}, started {holder.get('started')}"
    if holder.get("command"):
        text += f": {holder['command']}"
    return text
