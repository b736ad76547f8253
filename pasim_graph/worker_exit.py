"""A local worker's exit without the interpreter's last garbage collections.

A worker process that has imported the numerical libraries and run chunks holds about a
million objects; its interpreter walks them all in the collections it makes on the way out
(0.4 s a worker, measured 2026-11-29), and its nanny, and so the closing of a LocalCluster,
waits for that. Frozen (:func:`gc.freeze`), they are left to the operating system, which
frees the process's memory whole: a two-worker cluster closed in 0.05 s instead of 0.45 s.
"""

from __future__ import annotations

import gc
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin


class FreezeAtClose(WorkerPlugin):
    """Registered on the LocalClusters this package starts (:func:`.cluster.open_client`):
    never on an external scheduler's workers, which outlive the client."""

    name = "pasim-freeze-at-close"
    idempotent = True

    def teardown(self, worker: Any) -> None:
        gc.freeze()
