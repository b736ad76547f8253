"""What a run will take before it runs: its store on disk, its chunks in memory, measured on
its first beam; the checks and errors that refuse a run that would not fit, and what a disk
that filled during the run left."""

from __future__ import annotations

import contextlib
import os
import shutil
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .store import StoreLock, run_state


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
#: its own malloc arena (reserved in 64 MiB heaps on 64-bit Linux) and an 8 MiB stack, and
#: OpenBLAS a 32 MiB buffer to each thread that calls it at once (measured: a process's
#: address space grows by 32 MiB at its first matrix product, numpy 2.4's OpenBLAS; without
#: it a run allowed narrowly ended in "OpenBLAS error: Memory allocation still failed"). It
#: counts only against an address-space limit (``ulimit -v``), which counts what is mapped.
THREAD_ADDRESS_SPACE = (64 + 8 + 32) * 2**20


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


#: How much more than its first-beam estimate a run may write (see check_resources).
DISK_MARGIN = 1.5


def tree_bytes(path: Path) -> int:
    total = 0
    for dirpath, _, files in os.walk(path):
        for name in files:
            with contextlib.suppress(OSError):
                total += os.lstat(os.path.join(dirpath, name)).st_size
    return total


def disk_full_message(path: Path, n_chunks: int, estimate: int) -> str:
    """One line: where a run found the disk full, what it kept and how to go on."""
    state = run_state(path) if path.exists() else None
    free = shutil.disk_usage(path if path.exists() else path.parent).free
    where = "while creating the store"
    if state is not None:
        where = f"with {int(state[1].sum())} of {n_chunks} chunks written"
    need = f"; the whole run writes about {gib(estimate)}" if estimate else ""
    keep = (
        "the store is kept: free space and complete it with --resume"
        if state is not None
        else "nothing was kept: free space and run it again"
    )
    return f"{path}: the disk is full ({where}; {gib(free)} free{need}); {keep}"


def check_resources(
    path: Path,
    probes: list[tuple[Probe, int]],
    lock: StoreLock,
    *,
    chunk_beams: int,
    at_most: int | None,
) -> int:
    """Refuse a run whose products would not fit the disk, or whose chunks the memory.

    ``probes`` holds each sweep's first-beam probe and its number of beams; ``at_most`` the
    chunks that run at once (None: a remote cluster's, whose memory is not ours to judge).
    Returns the bytes the store will take.
    """
    disk = sum(p.stored_bytes * n + p.layout_bytes for p, n in probes)
    n_beams = sum(n for _, n in probes)
    free = shutil.disk_usage(path).free
    if lock.replacing:
        free += tree_bytes(path)  # the store being replaced is freed before writing
    # Beams compress differently (storm against clear air): the estimate was 0.74 to
    # 1.08 of what the example graphs wrote on the bundled scene (0.28 for the uniform
    # scene's sub-megabyte store; docs/reliability.md), so the run is refused unless a
    # half more than the estimate fits.
    if DISK_MARGIN * disk > free:
        per_beam = sum(p.stored_bytes * n for p, n in probes) / max(n_beams, 1)
        sweeps = f" in {len(probes)} sweeps" if len(probes) > 1 else ""
        raise ResourceError(
            f"this run would write about {gib(disk)} to {path} "
            f"({gib(per_beam)} per beam x {n_beams} beams{sweeps}, compressed, plus "
            f"its layout; up to {DISK_MARGIN:g}x that in beams full of echo) and "
            f"{gib(free)} is free there; write fewer fields (--outputs, no --save-iq), "
            "fewer beams, or choose another --out"
        )
    if at_most is None:
        return disk
    for probe, n in probes:
        at_once = min(at_most, -(-n // chunk_beams))
        beams = min(chunk_beams, n)
        need = probe.shared_bytes + probe.working_bytes * beams * at_once
        threads = ""
        if address_space_limited() and at_once > 1:
            need += THREAD_ADDRESS_SPACE * at_once
            threads = f", plus {gib(THREAD_ADDRESS_SPACE * at_once)} of threads' address space"
        available = memory_available()
        if need > available:
            raise ResourceError(
                f"this run would need about {gib(need)} of memory ({gib(probe.working_bytes)} "
                f"per beam x {beams} beams per chunk x {at_once} chunks at once, plus "
                f"{gib(probe.shared_bytes)} shared{threads}) and {gib(available)} is available; "
                "use a smaller --chunk or fewer --workers"
            )
    return disk


def chunks_at_once(
    workers: int | None, scheduler: str | None, local: tuple[str, ...]
) -> int | None:
    """How many chunks run at once in this process's memory (None: on a remote cluster)."""
    if scheduler not in (None, *local):
        return None
    if workers:
        return workers
    if scheduler == "sync":
        return 1
    return os.cpu_count() or 1
