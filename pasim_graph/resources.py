"""What a run will take before it runs: its store on disk, its chunks in memory, measured on
its first beam; and the errors that refuse a run that would not fit."""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr


class ResourceError(RuntimeError):
    """The run would not fit the memory or the disk (estimated before its chunks run)."""


class DiskFullError(ResourceError):
    """The disk filled while the run wrote its store (the store is kept, resumable)."""


@dataclass
class Probe:
    """What running the first beam alone showed: memory it held and what it stores."""

    working_bytes: int  # peak memory of one beam above what stays allocated after it
    shared_bytes: int  # memory that stays allocated after it (prepared inputs, memoised)
    stored_bytes: int  # compressed size of the beam's stored products
    layout_bytes: int = 0  # the store's metadata and the arrays written once


def gib(n: float) -> str:
    if n >= 2**30:
        return f"{n / 2**30:.1f} GiB"
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 2**10:.0f} KiB"


def stored_bytes(sweep: xr.Dataset, beam_dim: str) -> int:
    """Bytes one beam's variables will take in the store, compressed as zarr compresses them.

    A beam's NaN gates (censored, not scored) compress to almost nothing, so the first beam
    alone, often clear air at the edge of a sector, under-estimates a store of storm beams
    (1.4 MB estimated, 3.9 MB written for the generic radar's 90 beams; 2.9 MB now). Each
    variable is counted as if every gate held a value: its raw size times the compression
    ratio of the beam's variables that have no NaN (measured on this beam), at least its own
    size.
    """
    import numcodecs

    codec = numcodecs.Zstd(level=0)
    raw, packed, full_raw, full_packed = 0, 0, 0, 0
    for var in sweep.data_vars.values():
        if beam_dim not in var.dims:
            continue
        data = np.ascontiguousarray(var.values)
        if not data.nbytes:
            continue
        size = len(codec.encode(data))
        raw, packed = raw + data.nbytes, packed + size
        if data.dtype.kind not in "fc" or not np.isnan(data).any():
            full_raw, full_packed = full_raw + data.nbytes, full_packed + size
    ratio = full_packed / full_raw if full_raw else 1.0
    return max(packed, int(raw * ratio))


#: How many :func:`traced` calls this module's tracing serves now (0: it traces nothing,
#: whether or not someone else turned tracemalloc on), and the lock that guards it.
_TRACING = threading.Lock()
_tracing = 0


def traced(fn: Callable[[], Any]) -> tuple[Any, tuple[int, int]]:
    """Call ``fn`` with tracemalloc on (numpy reports its buffers to it).

    Returns fn's result and (peak above what remains allocated after it, what remains).
    """
    import tracemalloc

    global _tracing
    # Tracing is per process: runs measured in several threads at once (a study's runs in
    # flight) share it, and the last to finish stops it (one stopping it under another
    # would leave the other's figures at zero). Their peaks then count each other's
    # allocations: an over-estimate, the safe side for the checks they feed.
    with _TRACING:
        if _tracing == 0 and not tracemalloc.is_tracing():
            tracemalloc.start()
            _tracing = 1
        elif _tracing:
            _tracing += 1
    try:
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        result = fn()
        current, peak = tracemalloc.get_traced_memory()
    finally:
        with _TRACING:
            if _tracing:
                _tracing -= 1
                if _tracing == 0:
                    tracemalloc.stop()
    kept = max(0, current - base)
    return result, (max(0, peak - base - kept), kept)


#: Address space a chunk's thread maps besides the memory it uses: glibc gives each thread
#: its own malloc arena (reserved in 64 MiB heaps on 64-bit Linux) and an 8 MiB stack. It
#: counts only against an address-space limit (``ulimit -v``), which counts what is mapped.
THREAD_ADDRESS_SPACE = (64 + 8) * 2**20


def address_space_limited() -> bool:
    """Whether this process runs under an address-space limit (``ulimit -v``)."""
    import resource

    return resource.getrlimit(resource.RLIMIT_AS)[0] != resource.RLIM_INFINITY


def memory_available() -> int:
    """Bytes this process can still allocate: the machine's available memory, or less under
    an address-space limit (``ulimit -v``) or a cgroup's memory limit (a container's)."""
    import resource

    import psutil

    out = int(psutil.virtual_memory().available)
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        out = min(out, soft - psutil.Process().memory_info().vms)
    for limit, usage in (
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes",
            "/sys/fs/cgroup/memory/memory.usage_in_bytes",
        ),
    ):
        try:
            cap = Path(limit).read_text().strip()
            if cap.isdigit() and int(cap) < 1 << 60:
                out = min(out, int(cap) - int(Path(usage).read_text().strip()))
                break
        except OSError:
            continue
    return max(out, 0)


def layout_bytes(root: xr.Dataset, sweep: xr.Dataset, beam_dim: str) -> int:
    """The store's metadata (about 1.5 kB a node, measured) and its arrays written once."""
    nodes = len(root.variables) + len(sweep.variables) + 3
    once = sum(v.nbytes for v in sweep.variables.values() if beam_dim not in v.dims)
    return 1536 * nodes + int(once) + int(sum(v.nbytes for v in root.variables.values()))


#: How much more than its first-beam estimate a run may write (see _check_resources).
DISK_MARGIN = 1.5


def tree_bytes(path: Path) -> int:
    total = 0
    for dirpath, _, files in os.walk(path):
        for name in files:
            with contextlib.suppress(OSError):
                total += os.lstat(os.path.join(dirpath, name)).st_size
    return total
