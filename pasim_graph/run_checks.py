"""Checks a store-writing run makes before and after writing: whether its products fit the
disk and its chunks the memory (from the first beam of each sweep), which chunks of a store
were damaged on disk (to be written again by ``--resume``), and what a full disk left."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .resources import (
    DISK_MARGIN,
    THREAD_ADDRESS_SPACE,
    Probe,
    ResourceError,
    address_space_limited,
    gib,
    memory_available,
    tree_bytes,
)
from .resume_key import ResumeError
from .store import DONE, check_chunks, run_state
from .store_lock import StoreLock


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


def damaged_chunks(path: Path, offsets: dict[str, tuple[int, int]]) -> list[int]:
    """The run's chunks whose stored data was damaged on disk (to be written again).

    ``offsets`` gives each sweep group its first chunk's index among the run's chunks and
    its number of chunks. Damage outside the per-beam arrays (metadata, coordinates) cannot
    be rewritten chunk by chunk: that store is refused, naming it.
    """
    n_chunks = sum(n for _, n in offsets.values())
    damage = check_chunks(path)
    redo, other = set(), []
    for d in damage:
        group = d.node.split("/", 1)[0]
        if d.chunk is not None and d.node == DONE:
            redo.add(d.chunk[0])
        elif d.chunk is not None and "/" in d.node and group in offsets and d.beam_axis is not None:
            first, count = offsets[group]
            if d.chunk[d.beam_axis] < count:
                redo.add(first + d.chunk[d.beam_axis])
        else:
            other.append(d)
    if other:
        raise ResumeError(
            f"{path}: " + "; ".join(map(str, other[:6])) + " cannot be rewritten by --resume "
            "(only whole chunks of the beams can); run it again with --overwrite"
        )
    return sorted(i for i in redo if i < n_chunks)


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
