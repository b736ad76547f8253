"""Runs started from the studio: ``pasim run`` subprocesses, their progress and results.

A run is the command line's own ``python -m pasim_graph run`` in a child process, so that a
block that crashes (or eats the memory) takes down the run, never the server. The graph it
runs is the document as edited in the page (saved or not), written to the run's folder with
the canonical writer; the store goes there too, never next to the user's graphs. Progress is
read from the store's per-chunk done flags (``store.run_state``), the same flags ``--resume``
uses. When the run finishes, its scores (``store.summarize``) and one PPI picture per moment
(from the ``pasim_graph.figures`` plugins: the block library's PPIs) are computed once and kept.
"""

from __future__ import annotations

import itertools
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..graph import parse_sector
from ..serialize import json_safe
from .documents import (
    Folder,
    RequestError,
    canonical,
    diff,
    path_problems,
    read_text,
    run_choices,
)

#: Beams per chunk of a studio run: small, so that progress moves in visible steps (the
#: numbers do not depend on the chunking).
CHUNK_BEAMS = 4


@dataclass
class Run:
    id: str
    label: str
    graph: str  # the graph file it was started from (relative to the folder)
    text: str  # the graph text that ran
    options: dict[str, Any]
    folder: Path
    command: list[str]
    state: str = "starting"  # starting, running, drawing, done, failed, cancelled
    phase: str = "starting"
    started: float = field(default_factory=time.time)
    finished: float | None = None
    chunks_done: int = 0
    chunks_total: int = 0
    log: deque = field(default_factory=lambda: deque(maxlen=200))
    error: str = ""
    scores: dict[str, Any] | None = None
    images: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    proc: subprocess.Popen | None = None

    @property
    def store(self) -> Path:
        return self.folder / "volume.zarr"

    def to_json(self) -> dict[str, Any]:
        end = self.finished or time.time()
        return {
            "id": self.id,
            "label": self.label,
            "graph": self.graph,
            "text": self.text,
            "options": self.options,
            "state": self.state,
            "phase": self.phase,
            "seconds": round(end - self.started, 1),
            "chunks_done": self.chunks_done,
            "chunks_total": self.chunks_total,
            "progress": self.progress,
            "log": list(self.log),
            "error": self.error,
            "scores": json_safe(self.scores),
            "images": self.images,
            "notes": self.notes,
            "store": str(self.store),
        }

    @property
    def progress(self) -> float:
        if self.state in ("drawing", "done"):
            return 1.0
        if self.chunks_total:
            return self.chunks_done / self.chunks_total
        return 0.0


class Runs:
    """The runs of one studio session; one runs at a time (a run uses every core)."""

    def __init__(
        self,
        folder: Folder,
        runs_dir: Path,
        cwd: Path | None = None,
        memory_bytes: int | None = None,
    ):
        from ..resources import memory_available

        self.folder = folder
        self.dir = runs_dir
        #: What a run may allocate beyond the program it loads (:mod:`.capped`): by default
        #: half the memory available when the studio started.
        self.memory_bytes = int(memory_bytes or memory_available() // 2)
        self.cwd = cwd or folder.cwd
        self.runs: dict[str, Run] = {}
        self._ids = itertools.count(1)
        self._lock = threading.Lock()

    def get(self, run_id: str) -> Run:
        run = self.runs.get(run_id)
        if run is None:
            raise RequestError(404, f"no run {run_id!r} in this session")
        return run

    def start(self, body: dict[str, Any]) -> Run:
        """Check a run request completely, then start it; :class:`RequestError` if refused."""
        rel = body.get("path") or "untitled.yaml"
        if not isinstance(rel, str):
            raise RequestError(400, "'path' must be text")
        spec, text = canonical(body.get("doc"), rel)
        _, refused = path_problems(spec, self.folder)
        if refused:
            # Refused by name, before the run looks at the file (or says whether it exists).
            raise RequestError(403, "; ".join(str(p) for p in refused))
        args: list[str] = []
        options: dict[str, Any] = {}
        sector = body.get("sector") or ""
        if not isinstance(sector, str):
            raise RequestError(400, "'sector' must be text such as 280:290")
        if sector.strip():
            _, problem = parse_sector(sector.strip())  # the engine's rule, as the command line's
            if problem:
                raise RequestError(400, f"sector {sector!r}: {problem}")
            options["sector"] = sector.strip()
            # One argument: a sector such as -10:10 must not read as an option.
            args.append(f"--sector={options['sector']}")
        truth = body.get("truth") or ""
        if truth:
            args += ["--truth", str(self.folder.truth_path(truth))]
            options["truth"] = truth
        level = body.get("level") or ""
        if level:
            choices = run_choices(body.get("doc"))["levels"]
            chosen = next((c for c in choices if c["label"] == level), None)
            if chosen is None:
                known = ", ".join(c["label"] for c in choices) or "none for this graph"
                raise RequestError(400, f"unknown fidelity level {level!r}; levels: {known}")
            for k, v in chosen["set"].items():
                args += ["--set", f"{chosen['block']}.{k}={v}"]
            options["level"] = level
        seed = body.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
            raise RequestError(400, f"seed: expected a whole number 0 to 2**32-1, found {seed!r}")
        options["seed"] = seed
        label = body.get("label") or ""
        if not isinstance(label, str) or len(label) > 200:
            raise RequestError(400, "'label' must be text of at most 200 characters")

        with self._lock:
            busy = [r for r in self.runs.values() if r.state in ("starting", "running")]
            if busy:
                raise RequestError(
                    409, f"run {busy[0].id} is still going; wait for it or cancel it first"
                )
            # A kept runs folder (--runs DIR) may hold the runs of an earlier session.
            run_id = str(next(self._ids))
            while (self.dir / f"run{run_id}").exists():
                run_id = str(next(self._ids))
            folder = self.dir / f"run{run_id}"
            folder.mkdir(parents=True)
            graph_file = folder / "graph.yaml"
            graph_file.write_text(text)
            command = [
                sys.executable,
                "-m",
                "pasim_graph.studio.capped",
                str(self.memory_bytes),
                "run",
                str(graph_file),
                "--out",
                str(folder / "volume.zarr"),
                "--chunk",
                str(CHUNK_BEAMS),
                "--seed",
                str(seed),
                *args,
            ]
            what = ", ".join(str(options[k]) for k in ("sector", "level") if k in options)
            edits = self._edits(rel, text)
            tail = (f" with {edits}" if edits else "") + (f" ({what})" if what else "")
            # Runs of different systems must not share a name: when this one's would repeat
            # an earlier run's, it says what differs from that run instead.
            same = [
                r
                for r in self.runs.values()
                if r.label.partition(": ")[2] == f"{Path(rel).name}{tail}"
            ]
            if same and same[-1].text != text:
                tail += f", unlike run {same[-1].id}: {_changes(same[-1].text, text)}"
            run = Run(
                run_id,
                label or f"run {run_id}: {Path(rel).name}{tail}",
                rel,
                text,
                options,
                folder,
                command,
            )
            self.runs[run_id] = run
        # Fewer allocator arenas: less address space for the same memory (see capped.py).
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "MALLOC_ARENA_MAX": "2"}
        run.proc = subprocess.Popen(
            command,
            cwd=self.cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
        )
        run.state = run.phase = "running"
        threading.Thread(target=self._watch_output, args=(run,), daemon=True).start()
        threading.Thread(target=self._watch_store, args=(run,), daemon=True).start()
        return run

    def _edits(self, rel: str, text: str) -> str:
        """The blocks a run's graph changes from the file on disk, for its label."""
        try:
            disk = read_text(self.folder.resolve(rel))
        except RequestError:
            return "unsaved edits"
        return _changes(disk, text)

    def _watch_output(self, run: Run) -> None:
        assert run.proc is not None and run.proc.stdout is not None
        for line in run.proc.stdout:
            line = line.rstrip()
            if not line:
                continue
            run.log.append(line)
            m = re.search(r": (\d+) beams in chunks of (\d+)", line)
            if m:
                beams, chunk = int(m[1]), int(m[2])
                run.chunks_total = -(-beams // chunk)
                run.phase = f"reading the truth and laying out the store ({beams} beams)"
            if line.startswith("note: "):
                run.notes.append(line.removeprefix("note: "))
        code = run.proc.wait()
        if run.state == "cancelled":
            run.finished = time.time()
            return
        if code != 0:
            run.state = "failed"
            run.phase = f"failed (exit code {code})"
            run.error = _failure(list(run.log))
            run.finished = time.time()
            return
        run.state, run.phase = "drawing", "scoring and drawing the PPIs"
        try:
            self._results(run)
            run.state, run.phase = "done", "done"
        except Exception as exc:  # a broken store must not leave the run "drawing" forever
            run.state, run.phase = "failed", "failed reading the results"
            run.error = f"reading the run's store failed: {type(exc).__name__}: {exc}"
        run.finished = time.time()

    def _watch_store(self, run: Run) -> None:
        from ..store import run_state

        while run.proc is not None and run.proc.poll() is None:
            if run.store.exists():
                state = run_state(run.store)  # None while the template is being written
                if state is not None:
                    done = state[1]
                    run.chunks_total = int(done.size)
                    run.chunks_done = int(done.sum())
                    run.phase = f"running: {run.chunks_done} of {run.chunks_total} chunks"
            time.sleep(0.2)

    def _results(self, run: Run) -> None:
        from ..registry import figure_makers
        from ..store import open_sweep, summarize

        sweep, _ = open_sweep(run.store)
        sweep = sweep.load()
        run.scores = summarize(sweep)
        makers = figure_makers()
        if not makers:
            run.notes.append("no package draws run pictures (pasim_graph.figures); scores only")
        for make in makers.values():
            pictures, notes = make(sweep, run.scores, 80)
            run.notes += notes
            for name, png in pictures:
                (run.folder / f"{name}.png").write_bytes(png)
                run.images.append(name)

    def rename(self, run_id: str, label: Any) -> Run:
        """Give a run the name the user typed (kept for the session, shown everywhere)."""
        run = self.get(run_id)
        if not isinstance(label, str) or not label.strip() or len(label) > 200:
            raise RequestError(400, "'label' must be text of 1 to 200 characters")
        if any(ord(c) < 32 for c in label):
            raise RequestError(400, "'label' must be one line of text")
        run.label = label.strip()
        return run

    def cancel(self, run_id: str) -> Run:
        run = self.get(run_id)
        if run.state in ("starting", "running") and run.proc is not None:
            run.state, run.phase = "cancelled", "cancelled"
            run.proc.terminate()
        return run

    def image(self, run_id: str, name: str) -> Path:
        run = self.get(run_id)
        if name not in run.images:
            raise RequestError(404, f"run {run_id} has no picture of {name!r}")
        return run.folder / f"{name}.png"

    def compare(self, a_id: str, b_id: str) -> dict[str, Any]:
        """Run B against run A: each score, and B minus A (B's change from A)."""
        a, b = self.get(a_id), self.get(b_id)
        for r in (a, b):
            if r.state != "done" or r.scores is None:
                raise RequestError(409, f"run {r.id} has no results yet ({r.state})")
        assert a.scores is not None and b.scores is not None
        rows = []
        for moment in dict.fromkeys([*a.scores, *b.scores]):
            sa, sb = a.scores.get(moment), b.scores.get(moment)
            row: dict[str, Any] = {"moment": moment, "a": sa, "b": sb}
            if sa and sb:
                row["bias_change"] = sb["bias"] - sa["bias"]
                row["abs_bias_change"] = abs(sb["bias"]) - abs(sa["bias"])
                row["std_change"] = sb["std"] - sa["std"]
                row["pass_change"] = (
                    "same"
                    if sa["pass"] == sb["pass"]
                    else ("now passes" if sb["pass"] else "now fails")
                )
            rows.append(row)
        options = {
            k: [a.options.get(k), b.options.get(k)]
            for k in sorted({*a.options, *b.options})
            if a.options.get(k) != b.options.get(k)
        }
        return json_safe(
            {
                "a": a.to_json() | {"log": []},
                "b": b.to_json() | {"log": []},
                "rows": rows,
                "graph_diff": diff(a.text, b.text, "graph.yaml"),
                "options_diff": options,
            }
        )

    def close(self, remove: bool) -> None:
        """Stop a run still going; remove the runs folder when it was a temporary one."""
        for run in self.runs.values():
            if run.proc is not None and run.proc.poll() is None:
                run.state = "cancelled"
                run.proc.terminate()
                try:
                    run.proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    run.proc.kill()
        if remove:
            shutil.rmtree(self.dir, ignore_errors=True)


def _failure(log: list[str]) -> str:
    """What went wrong, from the run's output: the engine's report, or the last lines."""
    for i, line in enumerate(log):
        if re.match(r"^\d+ problems? in the graph:", line) or line.startswith("error: "):
            return "\n".join(log[i:])
    return "\n".join(log[-15:]) or "the run stopped without saying why"


def _changes(old_text: str, new_text: str) -> str:
    """What a graph's text changes from another's, in a few words (at most three items)."""
    from ..graphfile import format_value, parse

    old, new = parse(old_text), parse(new_text)
    out = []
    for name in sorted(set(old.blocks) | set(new.blocks)):
        a, b = old.blocks.get(name), new.blocks.get(name)
        if a is None or b is None:
            out.append(f"{'+' if a is None else '-'}{name}")
        elif a.type != b.type:
            out.append(f"{name}: {b.type}")
        else:
            for k in sorted(set(a.params) | set(b.params)):
                if a.params.get(k) != b.params.get(k):
                    out.append(f"{name}.{k}={format_value(b.params.get(k))}")
    if sorted(map(str, old.connections)) != sorted(map(str, new.connections)):
        out.append("rewired")
    if old.variables != new.variables:
        out.append("variables changed")
    return ", ".join(out[:3]) + (", ..." if len(out) > 3 else "")
