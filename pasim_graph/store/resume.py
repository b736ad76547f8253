"""Resuming a store: what must match (the run key: the graph as run, the content of the files
it reads, the program's version, seed, chunking, products), why a store's differs, and which
of its chunks were damaged on disk and must be written again."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .check import check_chunks
from .format import DONE

if TYPE_CHECKING:
    from ..executor import RunOptions
    from ..graph import Graph


class ResumeError(RuntimeError):
    """The store cannot be resumed by this run (another graph, seed or chunking)."""


def input_paths(graph: Graph) -> dict[str, str]:
    """The files a graph reads: every set ``path`` parameter, as ``{BLOCK.PARAM: path}``."""
    out = {}
    for block, cls in sorted(graph.classes.items()):
        for name, param in cls.params.items():
            value = graph.value(block, name)
            if param.type == "path" and value:
                out[f"{block}.{name}"] = str(value)
    return out


def file_digest(path: str | Path) -> str | None:
    """The SHA-256 of a file's content (a Zarr store: each of its files, by its path inside
    the store); None where it cannot be read."""
    path = Path(path)
    digest = hashlib.sha256()
    try:
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for file in files:
            if file != path:
                digest.update(str(file.relative_to(path)).encode() + b"\0")
            with open(file, "rb") as f:
                while piece := f.read(1 << 20):
                    digest.update(piece)
    except OSError:
        return None  # validation names a missing file; the block's load says the rest
    return digest.hexdigest()


def input_digests(graph: Graph) -> dict[str, str]:
    """The content of every file a graph reads (``path`` parameters), as SHA-256 digests.

    A truth file replaced at the same path is another experiment: its digest differs.
    """
    out = {}
    for key, path in input_paths(graph).items():
        digest = file_digest(path)
        if digest is not None:
            out[key] = digest
    return out


def run_key(graph: Graph, options: RunOptions, inputs: dict[str, str] | None = None) -> str:
    """What must match for a store to be resumed: the graph as run, the content of the files
    it reads, the program's version, seed, chunking, products."""
    from .. import __version__

    text = json.dumps(
        {
            "graph": graph.text(),
            "inputs": input_digests(graph) if inputs is None else inputs,
            "version": __version__,
            "seed": options.seed,
            "chunk_beams": options.chunk_beams,
            "products": sorted(options.wanted),
            "fields": sorted(options.fields) if options.fields is not None else None,
        },
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def resume_mismatch(path: Path, stored: dict[str, Any], inputs: dict[str, str]) -> str:
    """Why a store's run key differs from this run's, as precisely as the store says."""
    from .. import __version__

    theirs = stored.get("pasim_graph_version")
    if theirs is not None and theirs != __version__:
        return (
            f"{path} was written by pasim-graph {theirs} and this is pasim-graph "
            f"{__version__}: resuming would mix chunks computed by different code; "
            "use --overwrite to run it again"
        )
    try:
        before = json.loads(stored.get("pasim_inputs", "null"))
    except ValueError:
        before = None
    if isinstance(before, dict):
        changed = sorted(k for k in set(before) | set(inputs) if before.get(k) != inputs.get(k))
        if changed:
            return (
                f"{path} was written from other input files: the content of "
                f"{', '.join(changed)} changed since (a file replaced at the same path); "
                "resuming would mix two experiments; use --overwrite to run it again"
            )
    return (
        f"{path} was written by another run (graph, seed, chunk "
        "size or products differ); use --overwrite to replace it"
    )


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
