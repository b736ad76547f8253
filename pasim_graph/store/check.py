"""Finding damage in a written store: every array its layout lists present, every chunk of
every array read under its checksum, and no symbolic link planted in it."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..fm301 import BEAM_DIMENSIONS


class NotAStoreError(ValueError):
    """The path is not a finished PASIM-graph run."""


#: The root attribute that lists every array of a store's layout (JSON: their paths in the
#: store, sorted), written with the layout, so that an array removed whole is named instead of
#: read as NaN (its chunks are checked only while its metadata is there).
ARRAYS = "pasim_arrays"


def arrays_on_disk(path: str | Path) -> list[str]:
    """The arrays a store holds: the nodes whose ``zarr.json`` says so, by path (sorted)."""
    root = Path(path)
    out = []
    for meta_path in root.rglob("zarr.json"):
        try:
            meta = json.loads(meta_path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(meta, dict) and meta.get("node_type") == "array":
            out.append(meta_path.parent.relative_to(root).as_posix())
    return sorted(out)


def array_list(path: str | Path, *also: str) -> dict[str, str]:
    """The root attribute that lists a layout's arrays: those in the store at ``path`` and
    ``also`` (written after it)."""
    return {ARRAYS: json.dumps(sorted({*arrays_on_disk(path), *also}))}


def listed_arrays(path: str | Path) -> list[str] | None:
    """The arrays a store's layout wrote: its list (:data:`ARRAYS`), or for a store written
    before the list existed, the arrays its consolidated metadata names (a finished run's).
    None when neither says (an old store that never finished) or the list is unreadable
    (:func:`check_chunks` names that)."""
    try:
        meta = json.loads((Path(path) / "zarr.json").read_text())
        attrs = meta.get("attributes") or {}
    except (OSError, ValueError, AttributeError):
        return None
    if ARRAYS in attrs:
        return _array_list(attrs[ARRAYS])
    consolidated = (meta.get("consolidated_metadata") or {}).get("metadata") or {}
    names = [n for n, m in consolidated.items() if (m or {}).get("node_type") == "array"]
    return sorted(names) or None


def _array_list(value: object) -> list[str] | None:
    try:
        names = json.loads(value) if isinstance(value, str) else None
    except ValueError:
        return None
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        return None
    return names


def missing_arrays(path: str | Path) -> list[str]:
    """The arrays a store's layout lists that are not in it (their metadata is gone)."""
    root = Path(path)
    return [n for n in listed_arrays(root) or [] if not (root / n / "zarr.json").is_file()]


def check_arrays(path: str | Path) -> None:
    """Raise :class:`MissingArraysError` naming the arrays a store's layout lists that are
    not in it."""
    missing = missing_arrays(path)
    if missing:
        raise MissingArraysError(path, missing)


class MissingArraysError(NotAStoreError):
    """A store that lacks arrays its layout lists (removed after the run wrote them)."""

    def __init__(self, path: str | Path, names: list[str]):
        self.path, self.names = Path(path), names
        one = len(names) == 1
        it = "it" if one else "them"
        super().__init__(
            f"{path}: {some(names, 6)} {'is' if one else 'are'} missing (the layout lists {it}); "
            f"write {it} again with the run's own command and --resume (graph, seed and "
            "options as stored), or run it again with --overwrite"
        )


def some(names: list[str], at_most: int = 5) -> str:
    """The first ``at_most`` of ``names``, and how many more there are."""
    more = f" and {len(names) - at_most} more" if len(names) > at_most else ""
    return ", ".join(names[:at_most]) + more


def symbolic_links(path: str | Path) -> list[str]:
    """Every symbolic link inside a store, by path (sorted): none of them is ours, and
    writing through one writes outside the store."""
    root = Path(path)
    out = []
    for dirpath, dirnames, filenames in os.walk(root):  # links to folders are not entered
        for name in dirnames + filenames:
            entry = Path(dirpath, name)
            if entry.is_symlink():
                out.append(entry.relative_to(root).as_posix())
    return sorted(out)


@dataclass(frozen=True)
class Damage:
    """One damaged piece of a store: an array's chunk, or a node's metadata."""

    node: str  # the array or group, relative to the store ("sweep_0/DBZH")
    chunk: tuple[int, ...] | None  # the chunk's grid index; None: the node's metadata
    why: str
    beam_axis: int | None = None  # the array's beam dimension, when it has one
    key: str | None = None  # the chunk's file under the array ("c.1.0", or "c/1/0" before)

    def __str__(self) -> str:
        if self.chunk is None:
            return f"{self.node}/zarr.json ({self.why})"
        key = self.key or ".".join(["c", *map(str, self.chunk)])
        return f"{self.node} chunk {key} ({self.why})"


def check_chunks(path: str | Path) -> list[Damage]:
    """Read every chunk of every array in a store and say which are damaged.

    Chunks are written under a CRC-32C checksum and every chunk is written (empty ones too),
    so a chunk file that was truncated, altered or removed after the run wrote it is found
    here instead of being read as wrong numbers or NaN.
    """
    import itertools

    import zarr

    root = Path(path)
    out: list[Damage] = []
    for meta_path in sorted(root.rglob("zarr.json")):
        node = meta_path.parent.relative_to(root).as_posix()
        node = "" if node == "." else node
        try:
            meta = json.loads(meta_path.read_text())
            if not isinstance(meta, dict) or meta.get("node_type") not in ("array", "group"):
                raise ValueError("not Zarr v3 metadata")
        except (OSError, ValueError) as exc:
            out.append(Damage(node or ".", None, f"unreadable: {_short(exc)}"))
            continue
        if meta["node_type"] != "array":
            if not node and ARRAYS in (meta.get("attributes") or {}):
                if _array_list(meta["attributes"][ARRAYS]) is None:
                    out.append(Damage(".", None, f"unreadable: its {ARRAYS} list"))
            continue
        try:
            arr = zarr.open_array(str(root), path=node, mode="r")
        except Exception as exc:
            out.append(Damage(node, None, f"cannot be opened: {_short(exc)}"))
            continue
        names = list(meta.get("dimension_names") or [])
        beam_axis = next((names.index(d) for d in BEAM_DIMENSIONS if d in names), None)
        grid = [-(-n // c) for n, c in zip(arr.shape, arr.chunks, strict=True)]
        missing = set()
        for idx in itertools.product(*(range(g) for g in grid)):
            # The array's own chunk-key encoding: c.1.0 (one folder an array), or c/1/0 in
            # stores written before 2026-11-29 (a folder a chunk)
            key = arr.metadata.encode_chunk_key(idx)
            if not meta_path.parent.joinpath(*key.split("/")).is_file():
                missing.add(idx)
                out.append(Damage(node, idx, "missing", beam_axis, key))
        out += _unreadable_chunks(arr, node, grid, missing, beam_axis)
    return out


#: Bytes of chunks read at once when a store is checked: zarr reads a slab's chunks together
#: (one call, not one per chunk), and a run of any size is checked in bounded memory.
CHECK_SLAB_BYTES = 64 << 20


def _unreadable_chunks(
    arr: Any, node: str, grid: list[int], missing: set[tuple[int, ...]], beam_axis: int | None
) -> list[Damage]:
    """The chunks of ``arr`` that cannot be read (checksum, codec), slab by slab along its
    first axis; a slab that fails is read again chunk by chunk to name the damaged ones."""
    import itertools
    import math

    if not grid:  # a scalar: one chunk
        grid_rest, rows = [], 1
    else:
        grid_rest = grid[1:]
        row_bytes = math.prod(arr.chunks) * arr.dtype.itemsize * math.prod(grid_rest)
        rows = max(1, CHECK_SLAB_BYTES // max(row_bytes, 1))
    out: list[Damage] = []
    first = grid[0] if grid else 1
    for start in range(0, first, rows):
        stop = min(first, start + rows)
        try:
            if grid:
                arr.blocks[start:stop]
            else:
                arr[...]
            continue
        except Exception:
            pass
        for idx in itertools.product(range(start, stop), *(range(g) for g in grid_rest)):
            idx = idx[: len(grid)]
            if idx in missing:
                continue
            try:
                arr.get_block_selection(idx)
            except Exception as exc:
                key = arr.metadata.encode_chunk_key(idx)
                out.append(Damage(node, idx, f"unreadable: {_short(exc)}", beam_axis, key))
    return out


def _short(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if "checksum" in text.lower():
        return "checksum mismatch"
    return text if len(text) <= 120 else text[:117] + "..."


class DamagedStoreError(NotAStoreError):
    """A finished store whose files were damaged after the run wrote them."""

    def __init__(self, path: str | Path, damage: list[Damage]):
        self.path, self.damage = Path(path), damage
        shown = "; ".join(map(str, damage[:6]))
        more = f"; and {len(damage) - 6} more" if len(damage) > 6 else ""
        super().__init__(
            f"{path} is damaged: {shown}{more}. Rewrite the damaged chunks with the run's own "
            "command and --resume (graph, seed and options as stored), or run it again with "
            "--overwrite"
        )
