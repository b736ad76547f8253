"""Taking a directory for a run: a store is a directory this program made, and nothing else is
ever written to or removed. A new store is marked first; an existing one is resumed, or
replaced only once the new run is ready to write; a run that fails before writing anything
leaves no trace.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

from .check import some, symbolic_links
from .format import MARKER, is_store, marker_cut_short, run_state, write_marker
from .lock import LOCK, StoreError, StoreLock


class StoreExistsError(FileExistsError):
    pass


def open_store(path: str | Path, *, overwrite: bool, resume: bool, command: str) -> StoreLock:
    """Take a directory for a run to write, refusing anything this program did not write.

    ``path`` may be missing or an empty directory (a new store), or a store of ours: with
    ``overwrite`` it is marked for replacement (emptied by :func:`replace_store` only once
    the new run is ready to write, so a run that fails first leaves it as it was), with
    ``resume`` it is kept for the run to complete; without either an existing store is
    refused. An overwrite is refused, naming them, when the store holds files this program
    did not write there (a user's notes or plots). A plain file, a non-empty
    directory without the marker (``.``, a home folder, a foreign Zarr), a store another
    run is writing, or a place that cannot be written raise :class:`StoreError` naming the
    path, before anything in it is touched. Returns the held lock.
    """
    path = Path(path)
    if overwrite and resume:
        raise StoreError("--resume and --overwrite exclude each other: choose one")
    if path.exists() and not path.is_dir():
        raise StoreError(f"{path} is a file, not a store directory; choose another --out")
    # A store another run is just making holds only its lock and a marker it may not have
    # finished writing: then the lock decides (and names that run).
    if path.is_dir() and not is_store(path) and set(_entries(path)) - {LOCK, MARKER}:
        what = (
            "a Zarr store written by something else"
            if (path / "zarr.json").exists()
            else ("a directory this program did not write")
        )
        raise StoreError(
            f"{path} is {what} (no {MARKER} in it); it is left untouched: choose another --out"
        )
    made_dirs = [p for p in (path, *path.parents) if not p.exists()]
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StoreError(f"cannot create {path}: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        readonly = bool(os.statvfs(path).f_flag & os.ST_RDONLY)
        why = "the file system is read-only" if readonly else "permission denied"
        raise StoreError(f"cannot write to {path}: {why}")
    lock = StoreLock.acquire(path, command)
    lock.made_dirs = made_dirs
    try:
        # Checked again under the lock: another run may have made the store meanwhile.
        existing = set(_entries(path)) - {LOCK}
        if existing == {MARKER} and marker_cut_short(path):
            # Only a marker cut short (a run stopped while marking its new store): nobody is
            # making it now (the lock is ours), so it is a new store, marked again below.
            existing = set()
        if existing and not is_store(path):
            raise StoreError(f"{path} is not a store this program wrote; choose another --out")
        if existing and not (overwrite or resume):
            crashed = " (a run that stopped early left it)" if lock.previous else ""
            raise StoreExistsError(
                f"{path} exists{crashed}; pass --resume to complete it or --overwrite to replace it"
            )
        links = symbolic_links(path) if existing and resume else []
        if links:
            raise StoreError(
                f"{path} holds symbolic links ({some(links)}); --resume would write through "
                "them, outside the store: remove them, or choose another --out"
            )
        if existing and overwrite:
            foreign = foreign_entries(path)
            if foreign:
                raise StoreError(
                    f"{path} holds files this program did not write ({some(foreign)}); "
                    "--overwrite would delete them: move them out of the store, or choose "
                    "another --out"
                )
            if run_state(path) is None:
                clear_store(path)  # nothing of a finished run to keep (a template cut short)
                existing = set()
            else:
                lock.replacing = True
        if not existing:
            lock.fresh = True
            write_marker(path)
    except BaseException:
        lock.release(restore=True)
        raise
    return lock


def replace_store(lock: StoreLock) -> None:
    """Empty a store taken with --overwrite, now that the new run is about to write it."""
    if lock.replacing:
        clear_store(lock.path.parent)
        lock.replacing = False
        lock.fresh = True


def discard_store(lock: StoreLock) -> None:
    """Undo a fresh store that holds nothing yet (its run failed before writing anything):
    remove the marker, the lock, and the directories the run made for it."""
    store = lock.path.parent
    if not (lock.fresh and is_store(store)) or run_state(store) is not None:
        return
    # zarr writes a layout's files concurrently: when one write failed, others may still be
    # landing. Wait until the tree is still, so nothing is written after it is removed.
    settle(store)
    clear_store(store)
    (store / MARKER).unlink()
    lock.release()
    for made in lock.made_dirs:
        try:
            made.rmdir()
        except OSError:
            break  # not empty: something else is in it now


def settle(path: Path, quiet_s: float = 0.2, limit_s: float = 5.0) -> None:
    """Wait until nothing under ``path`` has changed for ``quiet_s`` (at most ``limit_s``)."""

    def snapshot() -> set[tuple[str, int, int]]:
        out = set()
        for dirpath, _, files in os.walk(path):
            for name in files:
                with contextlib.suppress(OSError):
                    st = os.lstat(os.path.join(dirpath, name))
                    out.add((os.path.join(dirpath, name), st.st_size, st.st_mtime_ns))
        return out

    start, last = time.monotonic(), snapshot()
    while time.monotonic() - start < limit_s:
        time.sleep(quiet_s)
        now = snapshot()
        if now == last:
            return
        last = now


def clear_store(path: Path) -> None:
    """Remove a store's contents but its marker and lock (only ever called on our stores)."""
    if not is_store(path):
        raise StoreError(f"{path} is not a store this program wrote; refusing to clear it")
    for name in set(_entries(path)) - {LOCK, MARKER}:
        entry = path / name
        if entry.is_dir() and not entry.is_symlink():
            _rmtree(entry)
        else:
            entry.unlink(missing_ok=True)


def _rmtree(path: Path) -> None:
    """Remove a tree; files that vanish meanwhile are fine (zarr's writer threads of a run
    that failed may still be renaming their partial files into place)."""
    import sys

    def missing_ok(func: Any, name: str, exc: Any) -> None:
        err = exc if isinstance(exc, BaseException) else exc[1]
        if not isinstance(err, FileNotFoundError):
            raise err

    if sys.version_info >= (3, 12):
        shutil.rmtree(path, onexc=missing_ok)
    else:
        shutil.rmtree(path, onerror=missing_ok)


def foreign_entries(path: Path) -> list[str]:
    """Entries of a store that this program did not write, relative to it (sorted).

    A store holds its marker, its lock and a Zarr v3 hierarchy: groups (a ``zarr.json`` and
    child nodes) and arrays (a ``zarr.json`` and their chunks under ``c``). Anything else was
    put there by someone else.
    """

    def walk(node: Path, rel: str) -> list[str]:
        out: list[str] = []
        try:
            meta = json.loads((node / "zarr.json").read_text())
        except (OSError, ValueError):
            meta = {}
        is_array = isinstance(meta, dict) and meta.get("node_type") == "array"
        for entry in sorted(node.iterdir(), key=lambda e: e.name):
            name = f"{rel}{entry.name}"
            if entry.name == "zarr.json" or (not rel and entry.name in (MARKER, LOCK)):
                continue
            if is_array:
                # chunks are files c.1.0 beside the metadata (c for a 0-d array), or, in
                # stores written before 2026-11-29, live under the folder c/
                if entry.is_symlink() or not _chunk_entry(entry):
                    out.append(name)
            elif entry.is_dir() and not entry.is_symlink() and (entry / "zarr.json").exists():
                out += walk(entry, name + "/")
            else:
                out.append(name)
        return out

    try:
        return walk(path, "")
    except OSError as exc:
        raise StoreError(f"cannot read {path}: {exc.strerror or exc}") from None


def _chunk_entry(entry: Path) -> bool:
    """Whether a file or folder beside an array's metadata holds its chunks: the folder c
    (a folder a chunk) or a file c or c.<index>.<index>... (a file a chunk), or such a file
    being written, which a killed run leaves: ``<key>.<hex>.partial`` (ours) or the key's
    last suffix replaced (zarr's: ``c.1.<hex>.partial`` for c.1.0, ``c.<hex>.partial`` for
    c.1 and c)."""
    name = entry.name
    if name == "c":
        return True
    parts = name.split(".")
    if len(parts) >= 3 and parts[-1] == "partial":
        parts = parts[:-2]
    return entry.is_file() and parts[0] == "c" and all(p.isdigit() for p in parts[1:])


def _entries(path: Path) -> list[str]:
    try:
        return sorted(e.name for e in path.iterdir())
    except OSError as exc:
        raise StoreError(f"cannot read {path}: {exc.strerror or exc}") from None
