"""``python -m pasim_graph.studio.capped BYTES ARGS...``: ``pasim ARGS`` with a memory cap.

The studio starts its runs through this module. It loads the program first (the command
line, the engine, the registered blocks and the libraries a run uses), then caps the
process's address space at what it holds plus ``BYTES`` (``RLIMIT_AS``), then runs the
command line. Two things follow:

- the run-size estimate the command line makes before any chunk runs
  (:func:`pasim_graph.resources.memory_available` reads the cap) refuses a run whose chunks
  would not fit, with its numbers, before the store is created;
- a run that grows past its estimate gets ``MemoryError`` (the command line names the block)
  instead of taking the machine's memory.
"""

from __future__ import annotations

import resource
import sys

#: Address space a run takes beyond the memory it uses: the modules and shared libraries its
#: blocks load, thread stacks and allocator arenas (with ``MALLOC_ARENA_MAX=2``, which the
#: studio sets). Measured on the generic radar: the address space grew by 566 MiB while the
#: resident memory grew by 275 MiB (1050 MiB without the arena bound).
ADDRESS_SLACK = 512 << 20


def cap_memory(extra_bytes: int) -> int:
    """Cap this process's address space at its current size plus ``extra_bytes`` (and the
    :data:`ADDRESS_SLACK`); returns the cap."""
    import psutil

    limit = int(psutil.Process().memory_info().vms) + ADDRESS_SLACK + int(extra_bytes)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    return limit


def main(argv: list[str]) -> int:
    if len(argv) < 2 or not argv[0].isdigit():
        print("usage: python -m pasim_graph.studio.capped BYTES ARGS...", file=sys.stderr)
        return 2
    # What every run loads, loaded before the cap: the cap is the run's own memory.
    import dask.array  # noqa: F401
    import xarray  # noqa: F401
    import zarr  # noqa: F401

    from .. import (
        dask_executor,  # noqa: F401
        registry,
    )
    from ..cli import main as cli_main

    registry.all_blocks()
    cap_memory(int(argv[0]))
    return cli_main(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
