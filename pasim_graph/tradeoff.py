"""Speed against accuracy: run one graph at every rung of a block's fidelity ladder.

A block declares its ladder (``Block.fidelity_ladder``: labelled parameter settings, fastest
first, most faithful last). :func:`tradeoff` runs the graph once per rung on the same scene,
seed and sector, each in a fresh process on one thread (BLAS included) so that time and peak
memory are the rung's own, and compares every rung's errors with the truth and with the most
faithful rung that was run.
"""

from __future__ import annotations

import collections
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .graph import Graph

#: A rung process's progress line on standard error: ``PROGRESS done total``.
PROGRESS = "pasim-tradeoff-progress"


class TradeoffError(RuntimeError):
    """The graph has no single fidelity ladder, or a rung failed."""


@dataclass(frozen=True)
class Rung:
    label: str
    block: str
    params: dict[str, Any]


def ladder(graph: Graph) -> list[Rung]:
    """The fidelity ladder of the one block in ``graph`` that declares one."""
    owners = [n for n, cls in graph.classes.items() if cls.fidelity_ladder]
    if len(owners) != 1:
        found = ", ".join(owners) or "none"
        raise TradeoffError(
            f"tradeoff needs exactly one block with a fidelity ladder in the graph; found {found}"
        )
    name = owners[0]
    return [Rung(label, name, dict(p)) for label, p in graph.classes[name].fidelity_ladder]


def ladder_keys(rungs: list[Rung]) -> list[str]:
    """The parameters a ladder sets, in the order its rungs first name them."""
    return list(dict.fromkeys(k for r in rungs for k in r.params))


def run_rung(
    graph_path: str,
    overrides: dict[str, Any],
    seed: int,
    chunk: int,
    on_chunk: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Run one rung in this process; returns timings, peak memory and the error fields."""
    from .executor import LocalExecutor, RunOptions
    from .graph import load

    graph = load(graph_path, overrides)
    executor = LocalExecutor(graph, RunOptions(seed=seed, chunk_beams=chunk))
    t0 = time.perf_counter()
    executor.load()
    t1 = time.perf_counter()
    sweep = executor.run(on_chunk=on_chunk)
    t2 = time.perf_counter()
    errors = {
        str(v.attrs.get("moment", k)): (v, dict(v.attrs))
        for k, v in sweep.data_vars.items()
        if v.attrs.get("pasim_role") == "error"
    }
    return {
        "seconds_load": t1 - t0,
        "seconds": t2 - t1,
        "seconds_by_block": dict(executor.block_seconds),
        "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "errors": errors,
    }


def _child(spec_file: str) -> None:
    """Entry of a rung's process: run it, save its errors, print its numbers as JSON."""
    from threadpoolctl import threadpool_limits

    spec = json.loads(Path(spec_file).read_text())
    # One thread, BLAS included: every level is timed on the same footing (per core).
    with threadpool_limits(limits=1, user_api="blas"):
        out = run_rung(
            spec["graph"], spec["overrides"], spec["seed"], spec["chunk"], on_chunk=_report
        )
    arrays = {k: np.asarray(v.values, dtype=np.float64) for k, (v, _) in out["errors"].items()}
    np.savez(str(spec["errors_file"]), **arrays)  # type: ignore[arg-type]
    periods = {k: a.get("period") for k, (_, a) in out["errors"].items()}
    print(
        json.dumps(
            {k: v for k, v in out.items() if k != "errors"} | {"periods": periods},
        )
    )


def _report(done: int, total: int) -> None:
    """A rung's progress, one line on standard error for the parent to read."""
    print(f"{PROGRESS} {done} {total}", file=sys.stderr, flush=True)


def _run_child(spec_file: Path, label: str, log: Any) -> tuple[int, str, str]:
    """Run a rung's process; its progress lines go to ``log`` as they come (a quarter at a
    time), the rest of its standard error is kept for a failure's message."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pasim_graph.tradeoff", str(spec_file)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stderr is not None
    kept: collections.deque[str] = collections.deque(maxlen=20)
    start, shown = time.perf_counter(), 0
    for line in proc.stderr:
        if line.startswith(PROGRESS):
            done, total = (int(x) for x in line.split()[1:3])
            quarter = 4 * done // total
            if log and quarter > shown:
                shown = quarter
                log(
                    f"level {label}: {done} of {total} chunks ({time.perf_counter() - start:.0f} s)"
                )
        else:
            kept.append(line)
    out = proc.stdout.read()
    return proc.wait(), out, "".join(kept)


def _std(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(v.std(ddof=1)) if v.size > 1 else math.nan


def _wrap(d: np.ndarray, period: float | None) -> np.ndarray:
    return d if not period else (d + period / 2) % period - period / 2


def tradeoff(
    graph: Graph,
    graph_path: str,
    overrides: dict[str, Any],
    *,
    seed: int = 0,
    chunk: int = 8,
    labels: list[str] | None = None,
    log: Any = None,
) -> list[dict[str, Any]]:
    """Run the ladder and return one row per rung (JSON-ready; NaN where undefined).

    Each row holds ``level`` (the rung's label), the ladder's parameter values, ``seconds``
    (everything but reading the inputs), ``seconds_<block>`` (the ladder block alone),
    ``peak_memory_mb`` (the rung process's peak resident memory), ``std`` (moment -> std of
    the error against truth), ``std_vs_reference`` (moment -> std of the difference from the
    reference rung's estimates, gate by gate) and ``count`` (scored gates per moment).
    """
    rungs = ladder(graph)
    if labels:
        known = [r.label for r in rungs]
        unknown = [x for x in labels if x not in known]
        if unknown:
            raise TradeoffError(
                f"unknown level(s) {', '.join(unknown)}; the ladder is {', '.join(known)}"
            )
        rungs = [r for r in rungs if r.label in labels]
    base = {k: graph.value(rungs[0].block, k) for k in ladder_keys(rungs)}
    results = []
    with tempfile.TemporaryDirectory(prefix="pasim-tradeoff-") as tmp:
        for i, rung in enumerate(rungs):
            settings = base | rung.params
            spec = {
                "graph": graph_path,
                "overrides": overrides | {f"{rung.block}.{k}": v for k, v in settings.items()},
                "seed": seed,
                "chunk": chunk,
                "errors_file": str(Path(tmp) / f"rung{i}.npz"),
            }
            spec_file = Path(tmp) / f"rung{i}.json"
            spec_file.write_text(json.dumps(spec))
            if log:
                log(f"level {rung.label} ({i + 1} of {len(rungs)}): {settings}")
            code, stdout, stderr = _run_child(spec_file, rung.label, log)
            if code != 0:
                tail = "\n".join(stderr.strip().splitlines()[-5:])
                raise TradeoffError(f"level {rung.label} failed:\n{tail}")
            numbers = json.loads(stdout.strip().splitlines()[-1])
            with np.load(str(spec["errors_file"])) as z:
                errors = {k: z[k] for k in z.files}
            results.append((rung, settings, numbers, errors))
    ref_errors, ref_periods = results[-1][3], results[-1][2]["periods"]
    rows = []
    for rung, settings, numbers, errors in results:
        vs_ref = {}
        for k, e in errors.items():
            if k in ref_errors:
                vs_ref[k] = _std(_wrap(e - ref_errors[k], ref_periods.get(k)))
        rows.append(
            {
                "level": rung.label,
                "block": rung.block,
                **settings,
                "seconds": numbers["seconds"],
                f"seconds_{rung.block}": numbers["seconds_by_block"].get(rung.block, math.nan),
                "seconds_load": numbers["seconds_load"],
                "peak_memory_mb": numbers["peak_memory_mb"],
                "std": {k: _std(e) for k, e in errors.items()},
                "std_vs_reference": vs_ref,
                "count": {k: int(np.isfinite(e).sum()) for k, e in errors.items()},
                "reference": results[-1][0].label,
            }
        )
    return rows


def format_table(rows: list[dict[str, Any]], keys: list[str]) -> str:
    """The rows as a text table: settings, time, memory, stds against truth and reference."""
    moments = list(dict.fromkeys(m for r in rows for m in r["std"]))
    block = rows[0]["block"]
    head = ["level", *keys, "seconds", f"{block}_s", "peak_MB"]
    head += [f"{m}" for m in moments] + [f"{m}~ref" for m in moments]
    lines = []
    for r in rows:
        cells = [str(r["level"]), *(str(r[k]) for k in keys)]
        cells += [f"{r['seconds']:.2f}", f"{r[f'seconds_{block}']:.2f}"]
        cells += [f"{r['peak_memory_mb']:.0f}"]
        cells += [f"{r['std'].get(m, math.nan):.3f}" for m in moments]
        cells += [f"{r['std_vs_reference'].get(m, math.nan):.3f}" for m in moments]
        lines.append(cells)
    widths = [max(len(h), *(len(c[i]) for c in lines)) for i, h in enumerate(head)]
    out = ["  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True))]
    out += ["  ".join(c.rjust(w) for c, w in zip(cells, widths, strict=True)) for cells in lines]
    ref = rows[-1]["level"]
    out.append(
        f"std of each moment's error against truth; '~ref': std of the gate-by-gate difference "
        f"from level {ref} (the most faithful run), same seed"
    )
    return "\n".join(out)


if __name__ == "__main__":
    _child(sys.argv[1])
