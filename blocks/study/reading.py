"""The errors of a study's finished stores, read as their runs finish.

The study scores once a minute and after its last run (:func:`.statistics.score_study`, which
takes the errors already read and reads the rest). Read there, every store not read in the
last minute was read after the last run: the one-seed paper study on two workers, 3.5 s of
its tail, 2.7 s of it checking every chunk's checksum. Each store is read as its run is
recorded instead: on the study's cluster as a task (the store is on the shared storage its
workers write), off the ``pasim`` process, whose one interpreter also sets up every run in
flight; without a cluster, here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .statistics import Errors, read_errors, root_token


def read_store(path: str) -> tuple[tuple[int, int], Errors]:
    """A finished store's token (:func:`.statistics.root_token`) and errors."""
    return root_token(Path(path)), read_errors(path)


class StoreReading:
    """Stores read into ``read`` (the cache :func:`.statistics.score_study` takes), by run
    key: here, or as tasks on ``client``'s cluster when one is given."""

    def __init__(self, read: dict[str, tuple[tuple[int, int], Errors]], client: Any = None):
        self.read, self.client = read, client
        self._flight: dict[str, Any] = {}  # run key -> future
        self._token = os.urandom(6).hex()  # keys of this study's own on a shared cluster

    def add(self, key: str, path: Path) -> None:
        """Read the finished store ``path`` of run ``key``: now, or sent to the cluster."""
        if self.client is None:
            self.read[key] = read_store(str(path))
            return
        self._flight[key] = self.client.submit(
            read_store, str(Path(path).absolute()), key=f"pasim-read-{self._token}-{key}"
        )

    def collect(self) -> None:
        """Wait for the stores sent and keep them (a store that cannot be read raises here,
        as it would have where the study scores)."""
        for key, future in list(self._flight.items()):
            self.read[key] = future.result()
            del self._flight[key]

    def drop(self) -> None:
        """Forget the reads in flight (the study stops: its scoring reads the stores)."""
        for future in self._flight.values():
            future.release()
        self._flight.clear()
