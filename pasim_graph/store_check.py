"""Finding damage in a written store: every chunk of every array read under its checksum."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path


class NotAStoreError(ValueError):
    """The path is not a finished PASIM-graph run."""


@dataclass(frozen=True)
class Damage:
    """One damaged piece of a store: an array's chunk, or a node's metadata."""

    node: str  # the array or group, relative to the store ("sweep_0/DBZH")
    chunk: tuple[int, ...] | None  # the chunk's grid index; None: the node's metadata
    why: str
    beam_axis: int | None = None  # the array's beam dimension, when it has one

    def __str__(self) -> str:
        if self.chunk is None:
            return f"{self.node}/zarr.json ({self.why})"
        key = "/".join(["c", *map(str, self.chunk)])
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
            continue
        try:
            arr = zarr.open_array(str(root), path=node, mode="r")
        except Exception as exc:
            out.append(Damage(node, None, f"cannot be opened: {_short(exc)}"))
            continue
        names = list(meta.get("dimension_names") or [])
        beam_axis = next(
            (names.index(d) for d in ("azimuth", "elevation", "time") if d in names), None
        )
        grid = [-(-n // c) for n, c in zip(arr.shape, arr.chunks, strict=True)]
        for idx in itertools.product(*(range(g) for g in grid)):
            chunk_file = meta_path.parent.joinpath("c", *map(str, idx))
            if not chunk_file.is_file():
                out.append(Damage(node, idx, "missing", beam_axis))
                continue
            try:
                arr.get_block_selection(idx)
            except Exception as exc:
                out.append(Damage(node, idx, f"unreadable: {_short(exc)}", beam_axis))
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
