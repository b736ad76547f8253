"""Results a block derives from its own state alone, kept for the process's later runs.

A block memoises what it derives from its parameters (a cylindrical array's pattern grid for
each beam offset) on its instance, which lives as long as its run. A study runs the same block
again and again (each system's seeds, its runs under each calibration), and a worker runs
chunks of many runs: each new instance filled its memo again (the 2 m CPPAR's grids, 5 s of
CPU in each 90 deg run, on every worker: docs/scaling.md). :class:`SharedResults`
keeps such results for the whole process, keyed by the block's whole state
(:func:`state_key`, a hash of the block as it is pickled) and the block's own key.

Keying by the whole state means a stale result is never returned: an instance whose state
differs in anything (a parameter, a pattern file's contents loaded into it, a prepared figure)
gets another key and computes afresh; two equal states built differently may miss, which costs
only the time it cost before. The results are made read-only: they are shared between runs.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import threading
from collections import OrderedDict
from collections.abc import Hashable
from typing import Any

import numpy as np

#: Bytes of results a process keeps beyond its runs (least recently used dropped first); an
#: instance keeps its own run's results in its own memo whatever this bound.
LIMIT_BYTES = int(os.environ.get("PASIM_SHARED_RESULTS_BYTES", str(1 << 30)))


def state_key(block: Any, state: Any = None) -> str:
    """A block's class and whole pickled state (its transient memos left out), hashed; or,
    given, the ``state`` its results depend on (a block that knows a parameter changes none
    of them leaves it out, and holds a test to it)."""
    kind = type(block)
    data = block if state is None else state
    digest = hashlib.blake2b(
        pickle.dumps(data, protocol=pickle.HIGHEST_PROTOCOL), digest_size=16
    ).hexdigest()
    return f"{kind.__module__}.{kind.__qualname__}:{digest}"


class SharedResults:
    """A bounded, thread-safe map of read-only arrays, least recently used dropped first."""

    def __init__(self, limit_bytes: int = LIMIT_BYTES):
        self.limit_bytes = limit_bytes
        self.nbytes = 0
        self.hits = 0
        self._items: OrderedDict[Hashable, np.ndarray] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable) -> np.ndarray | None:
        with self._lock:
            value = self._items.get(key)
            if value is not None:
                self._items.move_to_end(key)
                self.hits += 1
            return value

    def put(self, key: Hashable, value: np.ndarray) -> np.ndarray:
        """Keep ``value`` (made read-only, and returned) unless it alone exceeds the bound."""
        value.flags.writeable = False
        if value.nbytes > self.limit_bytes:
            return value
        with self._lock:
            old = self._items.pop(key, None)
            if old is not None:
                self.nbytes -= old.nbytes
            self._items[key] = value
            self.nbytes += value.nbytes
            while self.nbytes > self.limit_bytes:
                _, dropped = self._items.popitem(last=False)
                self.nbytes -= dropped.nbytes
        return value

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self.nbytes = 0
            self.hits = 0

    def __len__(self) -> int:
        return len(self._items)


#: The process's shared results (a worker's, or this process's own runs').
SHARED = SharedResults()
