"""The process's shared results (:mod:`pasim_graph.memo`): bounded, least recently used
dropped first, read-only, keyed by a block's whole state."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pasim_graph import Block, Param
from pasim_graph.memo import SharedResults, state_key


class Grid(Block):
    step_deg = Param(0.1, units="deg", doc="grid step")
    transient = ("_memo",)

    def setup(self) -> None:
        self.axis = np.arange(0.0, 1.0, self.p["step_deg"])
        self._memo: dict | None = {}


def test_least_recently_used_go_first_and_the_bound_holds() -> None:
    memo = SharedResults(limit_bytes=3 * 800)
    arrays = {k: np.full(100, float(k)) for k in range(4)}  # 800 bytes each
    for k in range(3):
        memo.put(k, arrays[k])
    assert memo.get(0) is arrays[0]  # 0 is now the most recently used
    memo.put(3, arrays[3])
    assert memo.get(1) is None and memo.get(0) is arrays[0] and memo.get(3) is arrays[3]
    assert memo.nbytes == 2400 and len(memo) == 3
    memo.put(3, np.zeros(100))  # replacing a key keeps the count right
    assert memo.nbytes == 2400
    big = np.zeros(400)
    assert memo.put("big", big) is big and memo.get("big") is None  # alone over the bound
    assert memo.hits == 3


def test_kept_results_are_read_only() -> None:
    memo = SharedResults()
    value = memo.put("k", np.zeros(3))
    assert not value.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        value[0] = 1.0


def test_state_key_follows_the_whole_state_not_the_memo() -> None:
    a, b = Grid("g"), Grid("g")
    assert state_key(a) == state_key(b)
    a._memo = {"filled": np.ones(5)}  # transient: not part of the state
    assert state_key(a) == state_key(b)
    assert state_key(Grid("g", step_deg=0.2)) != state_key(a)
    b.axis = b.axis + 1e-12  # state derived in set-up, changed: another key
    assert state_key(b) != state_key(a)
    clone = pickle.loads(pickle.dumps(a))
    assert state_key(pickle.loads(pickle.dumps(clone))) == state_key(clone)
