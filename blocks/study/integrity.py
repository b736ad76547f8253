"""What ties a study's folder to the study that wrote it.

- The study's inputs (:func:`study_inputs`): the package version, the study file, every
  system's graph file and every file a run reads through a ``path`` parameter (truths,
  pattern, waveform, coupling files), each by the SHA-256 of its content. Kept in the
  manifest; ``--resume`` refuses a folder whose inputs changed, naming them
  (:func:`changed_inputs`): finished stores and measured beamwidths of the old inputs would
  otherwise be mixed with runs of the new ones.
- Each store's identity (:func:`store_mismatch`): a finished store found in a run's place is
  kept only when its own attributes say it is that run (system, case, point, kind, seed) and
  its run key is the one the run would write; otherwise the study refuses it by name.
"""

from __future__ import annotations

import hashlib
from collections import defaultdict
from pathlib import Path
from typing import Any

from pasim_graph.store import file_digest

from .model import Study
from .plan import Run

#: The study file's entry among a study's inputs (its seeds may change: ``runner.added_seeds``).
STUDY_FILE = "the study file"


def study_inputs(study: Study, runs: list[Run]) -> dict[str, Any]:
    """``{"version", "files": {what: {"path", "sha256"}}}``: the package version and the
    content of everything the study's runs read (a file that cannot be read: ``"missing"``).
    Files are named by their role, not their path, so that a study folder moved together
    with its files still resumes."""
    from pasim_graph import __version__

    files = {
        STUDY_FILE: {
            "path": study.file,
            "sha256": hashlib.sha256(study.text.encode()).hexdigest(),
        }
    }
    for system in study.systems:
        files[f"the graph file of system '{system.name}'"] = _entry(system.graph, {})
    paths: dict[tuple[str, str], set[str]] = defaultdict(set)
    for run in runs:
        for param, path in run.inputs.items():
            paths[(run.system, param)].add(path)
    digests: dict[str, dict[str, str]] = {}  # a file read by many runs is hashed once
    for (name, param), found in sorted(paths.items()):
        for path in sorted(found):
            which = param if len(found) == 1 else f"{param} = {Path(path).name}"
            files[f"{which} of system '{name}'"] = _entry(path, digests)
    return {"version": __version__, "files": files}


def _entry(path: str | Path, digests: dict[str, dict[str, str]]) -> dict[str, str]:
    if str(path) not in digests:
        digests[str(path)] = {"path": str(path), "sha256": file_digest(path) or "missing"}
    return digests[str(path)]


def changed_inputs(before: Any, now: dict[str, Any]) -> str:
    """Why a study folder's inputs (``before``) differ from the study's ``now`` ("" when
    they do not)."""
    if not isinstance(before, dict) or not isinstance(before.get("files"), dict):
        return (
            "it was begun by a pasim-graph that did not record the study's input files, so "
            "they cannot be checked"
        )
    if before.get("version") != now["version"]:
        return (
            f"it was begun by pasim-graph {before.get('version')} and this is pasim-graph "
            f"{now['version']}"
        )
    old, new = before["files"], now["files"]
    changed = [
        f"{k} ({v['path']})"
        for k, v in new.items()
        if k in old and (old[k] or {}).get("sha256") != v["sha256"]
    ]
    if changed:
        return f"the content of {'; '.join(changed)} changed since it began"
    added = [f"{k} ({new[k]['path']}) is read now" for k in new if k not in old]
    gone = [f"{k} is no longer read" for k in old if k not in new]
    if added or gone:
        return f"the study reads other files than when it began: {'; '.join(added + gone)}"
    return ""


def identity(run: Run) -> dict[str, Any]:
    """The attributes by which a store says which run of a study it is."""
    return {
        "study_system": run.system,
        "study_case": run.case,
        "study_point": run.point_name,
        "study_run": run.kind,
        "seed": run.seed,
    }


def store_mismatch(attrs: dict[str, Any], run: Run, key: str) -> str:
    """Why a store (its root ``attrs``) is not ``run`` with run key ``key`` ("" when it is)."""
    for name, want in identity(run).items():
        got = attrs.get(name)
        if got is None:
            return f"it has no {name} attribute (it was not written by this study)"
        if str(got) != str(want):
            return f"its {name} is {got!r}, this run's is {want!r}"
    got = attrs.get("pasim_run_key")
    if got != key:
        return (
            f"its run key {got} is not this run's {key} (written from another graph, input "
            "files or program version)"
        )
    return ""
