"""How `pasim run` and `pasim study` scale over workers on this machine (run by hand, not in CI).

    python benchmarks/bench_scaling.py [--sector 0:360] [--workers 1,2] [--repeat 2]
        [--study graphs/paper_study.yaml --study-sector 240:270] [--baseline-pythonpath DIR]

For each worker count (alternating, ``--repeat`` rounds), runs the graph in a fresh `pasim run
--workers W` process and reads back the store's task record (``pasim_tasks``: every chunk
task's start, stop, worker and bytes, and the set-up steps). With ``--baseline-pythonpath``
the same command also runs under another build of the code (a folder holding ``pasim_graph``
and ``pasim_blocks``; a checkout's ``blocks/`` is found only through an install, so for a
checkout give ``--baseline-python``, a venv's interpreter with it installed), back to back
with this one, for paired ratios. Then runs the study
(its sector cut to ``--study-sector`` to keep it short) at each worker count and measures the
share of the cores its processes kept busy: CPU seconds of all its processes / (wall x W).

The makespan model, fitted on the one-worker runs' records (each term the median of the
runs' own, :func:`fit_graph_model`):

- each beam's cost (its chunk's compute time spread over its beams, in scan order), a task's
  fixed cost (writing its region and flag: the median write time), the scheduler's cost
  per task (the median gap between one task's end and the next one's start on a worker) and
  a worker's first-use cost (its first chunk's compute time beyond a typical chunk's: the
  prepared truth cells, paid once on every worker);
- the run's fixed cost: its whole wall time less its chunk phase (imports, inputs, layout,
  starting the cluster);
- the chunk phase at W workers: the chunks that ``choose_chunk`` gives for W, handed in scan
  order to whichever worker is free first (what dask does with equal priorities), each
  worker's first one paying the first-use cost; and never shorter than the phase's CPU
  (every worker process's while its tasks ran, the `pasim` process's, and the first-use
  cost once a worker) over the cores the machine has: the predictions for 16 workers and
  more give each worker a core.

The model is checked against every measurement made here (predicted and measured wall time,
the 2-worker one within 15 %), then predicts 16, 64, 256 and 1,000 workers. The load average
is recorded with every measurement: on a shared machine the ratios are the part to quote.
Prints JSON lines (and appends them to ``--out``) and a summary.
"""

from __future__ import annotations

import argparse
import calendar
import heapq
import itertools
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pasim_graph.dask_executor import choose_chunk  # noqa: E402
from pasim_graph.task_record import read_tasks  # noqa: E402

PHASES = re.compile(r"set-up ([\d.]+) s, (\d+) of (\d+) chunks in ([\d.]+) s")
MEASURED = re.compile(r"^measured .*: ([\d.]+) s$", re.M)
REPORTED = re.compile(r"report\.html in ([\d.]+) s \((\d+) figures, ([\d.]+) s of drawing")


def timed(cmd: list[str], env: dict[str, str]) -> dict[str, Any]:
    """Run ``cmd``; its wall time, the CPU seconds of it and all its descendants, the load."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    began = time.time()
    t0 = time.perf_counter()
    # Not from the repository: `python -m` puts the working folder first on the path, and a
    # baseline interpreter would import this checkout's engine instead of its own.
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return {
        "began": began,
        "wall_s": wall,
        "cpu_s": cpu,
        "load_before": load,
        "load_after": os.getloadavg()[0],
        "stderr": proc.stderr,
    }


def file_cost_ms(folder: str | Path, files: int = 300) -> float:
    """CPU (user and kernel) in ms to create one 5 KB file in ``folder`` now, written beside
    and renamed as a chunk file is, in fresh sub-folders, then removed. A run writes a file per
    array and chunk (the generic radar over 0:360: 1,080): on the 2-core test machine this cost
    was 0.03 ms in one folder and 0.8 ms in another at the same minute, and changed within
    minutes (docs/scaling.md), which moves the chunk phase by up to a second."""
    probe = Path(tempfile.mkdtemp(dir=folder, prefix="file-cost-"))
    data = b"x" * 5000
    try:
        t = os.times()
        for i in range(files):
            where = probe / f"v{i % 23}" / "c"
            where.mkdir(parents=True, exist_ok=True)
            (where / f"{i}.partial").write_bytes(data)
            os.replace(where / f"{i}.partial", where / str(i))
        u = os.times()
    finally:
        shutil.rmtree(probe, ignore_errors=True)
    return round(1000 * ((u.user - t.user) + (u.system - t.system)) / files, 3)


def environment(pythonpath: str | None) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    return env


def python(args: argparse.Namespace, build: str) -> str:
    """The interpreter of a build: this one's, or ``--baseline-python`` (another venv)."""
    return args.baseline_python if build == "baseline" and args.baseline_python else sys.executable


def foreign_packages(interpreter: str, pythonpath: str) -> str:
    """What of the baseline build would not come from ``pythonpath`` ("" when both
    packages do). A checkout holds the block library as ``blocks/``, found as
    ``pasim_blocks`` only through an install: with a PYTHONPATH alone the baseline would run
    this build's blocks (2026-11-29: a block change measured against itself)."""
    code = "import pasim_graph as g, pasim_blocks as b; print(g.__file__); print(b.__file__)"
    found = subprocess.run(
        [interpreter, "-c", code],
        env=environment(pythonpath),
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),  # as timed runs them
    ).stdout.split()
    root = Path(pythonpath).resolve()
    away = [f for f in found if root not in Path(f).resolve().parents]
    if len(found) != 2 or away:
        return (
            f"the baseline's packages come from {', '.join(away) or 'nowhere'}, not from it: "
            "give --baseline-python, the interpreter of a venv with the baseline installed"
        )
    return ""


def graph_run(args: argparse.Namespace, workers: int, build: str, pythonpath: str | None) -> dict:
    with tempfile.TemporaryDirectory(dir=args.store_dir) as tmp:
        out = Path(tmp) / "run.zarr"
        cmd = [python(args, build), "-m", "pasim_graph", "run", args.graph, "--sector", args.sector]
        cmd += ["--workers", str(workers), "--out", str(out), *args.run_args]
        file_ms = file_cost_ms(tmp)
        m = timed(cmd, environment(pythonpath))
        phases = PHASES.search(m.pop("stderr"))
        row: dict[str, Any] = {"case": "graph", "build": build, "workers": workers, **m}
        row["store_dir"], row["file_ms"] = str(Path(tmp).parent), file_ms
        if phases:
            row["setup_s"], row["chunks_s"] = float(phases[1]), float(phases[4])
            row["chunks"] = int(phases[3])
        row["digest"] = digest(out)
        try:
            row["record"] = read_tasks(out)[-1]
        except Exception:  # a build that keeps no record
            row["record"] = None
    return row


def digest(store: Path) -> str:
    """One hash of every array's values in the store (not its attributes, which hold times):
    equal digests, bit-identical stored numbers."""
    import hashlib

    import numpy as np
    import zarr

    h = hashlib.sha256()
    root = zarr.open_group(str(store), mode="r")
    for name, array in sorted(root.arrays(), key=lambda a: a[0]):
        if name == "pasim_chunk_done":  # one flag a chunk: as many as the chunking makes
            continue
        h.update(name.encode())
        h.update(np.ascontiguousarray(array[...]).tobytes())
    for gname, group in sorted(root.groups(), key=lambda g: g[0]):
        for name, array in sorted(group.arrays(), key=lambda a: a[0]):
            h.update(f"{gname}/{name}".encode())
            h.update(np.ascontiguousarray(array[...]).tobytes())
    return h.hexdigest()[:16]


def study_run(args: argparse.Namespace, workers: int, build: str, pythonpath: str | None) -> dict:
    with tempfile.TemporaryDirectory(dir=args.store_dir) as tmp:
        kept = Path(args.keep) / f"{build}_w{workers}" if args.keep else None
        study = Path(tmp) / "study.yaml"
        text = Path(args.study).read_text()
        # The study's own sector, cut short; its graphs are found next to the original file.
        text = re.sub(r'sector: "[^"]*"', f'sector: "{args.study_sector}"', text)
        text = re.sub(r"seeds: \[[^\]]*\]", "seeds: [0]", text)
        text = re.sub(
            r"graph: (\S+?)\}",
            lambda g: f"graph: {Path(args.study).parent.resolve() / g[1]}}}",
            text,
        )
        study.write_text(text)
        out = kept if kept is not None else Path(tmp) / "out"
        if kept is not None:
            shutil.rmtree(kept, ignore_errors=True)
        cmd = [python(args, build), "-m", "pasim_graph", "study", str(study), "--out", str(out)]
        cmd += ["--workers", str(workers)]
        m = timed(cmd, environment(pythonpath))
        err = m.pop("stderr")
        # Work done as cluster tasks beside the runs' chunks: the measurements (their seconds
        # on their workers) and, after the runs, the report's figures.
        m["measure_s"] = sum(float(x) for x in MEASURED.findall(err))
        report = REPORTED.search(err)
        if report:
            m["report_s"], m["figures"], m["figures_s"] = (
                float(report[1]),
                int(report[2]),
                float(report[3]),
            )
        # The study's measurement tasks (where and when each ran, its CPU), and the `pasim`
        # process's CPU while the runs ran.
        try:
            manifest = json.loads((out / "pasim-study.json").read_text())
        except (OSError, ValueError):
            manifest = {}
        measurements = manifest.get("measurements", [])
        process = manifest.get("process", [])
        records = []
        for store in sorted((out / "runs").rglob("*.zarr")):
            try:
                records.append(read_tasks(store)[-1])
            except Exception:
                pass
    busy = m["cpu_s"] / (m["wall_s"] * workers)
    return {
        "case": "study",
        "build": build,
        "workers": workers,
        **m,
        "busy": busy,
        "records": records,
        "measurements": measurements,
        "process": process,
    }


def beam_costs(record: dict) -> tuple[list[float], float, float, float]:
    """Per-beam compute cost in scan order (a worker's first-use cost taken out of its first
    chunk), a task's write cost, the scheduler's gap and the first-use cost (wall time)."""
    tasks = sorted(record["tasks"], key=lambda t: t["index"])
    compute = {t["index"]: t["computed"] - t["start"] for t in tasks}
    by_worker: dict[str, list[dict]] = {}
    for t in tasks:
        by_worker.setdefault(t["worker"], []).append(t)
    firsts = {min(ts, key=lambda t: t["start"])["index"] for ts in by_worker.values()}
    rest = [c for i, c in compute.items() if i not in firsts] or list(compute.values())
    typical = statistics.median(rest)
    first_use = statistics.median(max(compute[i] - typical, 0.0) for i in firsts)
    costs: list[float] = []
    for t in tasks:
        lo, hi = t["beams"]
        own = compute[t["index"]] - (first_use if t["index"] in firsts else 0.0)
        costs += [own / (hi - lo)] * (hi - lo)
    write = statistics.median(t["stop"] - t["computed"] for t in tasks)
    gaps = []
    for ts in by_worker.values():
        ts.sort(key=lambda t: t["start"])
        gaps += [b["start"] - a["stop"] for a, b in itertools.pairwise(ts)]
    gap = statistics.median(gaps) if gaps else 0.0
    return costs, write, max(gap, 0.0), first_use


def makespan(
    costs: list[float], write: float, gap: float, workers: int, chunk: int, first_use: float = 0.0
) -> float:
    """Chunks handed in scan order to whichever worker is free first; each worker's first
    chunk pays the first-use cost (the prepared truth cells: once a worker)."""
    free = [(0.0, i) for i in range(workers)]
    started: set[int] = set()
    for start in range(0, len(costs), chunk):
        t, w = heapq.heappop(free)
        extra = first_use if w not in started else 0.0
        started.add(w)
        heapq.heappush(free, (t + sum(costs[start : start + chunk]) + write + gap + extra, w))
    return max(t for t, _ in free)


def graph_model(row: dict) -> dict:
    record = row["record"]
    costs, write, gap, first_use = beam_costs(record)
    chunk = record["chunk_beams"]
    phase = makespan(costs, write, gap, 1, chunk, first_use)
    tasks = record["tasks"]
    steps = {s["kind"]: s for s in record["steps"]}
    # The CPU the chunk phase needs beyond a worker's first use: every worker process's CPU
    # while its tasks ran (their writes' threads and event loops included) and the `pasim`
    # process's over the phase (the scheduler, nannies and client). Records from before
    # these fields give the tasks' own threads only.
    cpu = sum(t.get("process_cpu_s", t["cpu_s"]) for t in tasks)
    first_cpu = min(first_use, max(t["cpu_s"] for t in tasks))
    return {
        "beams": len(costs),
        "beam_s": statistics.median(costs),
        "write_s": write,
        "gap_s": gap,
        "first_use_s": first_use,
        "phase_cpu_s": cpu - first_cpu + steps.get("chunks", {}).get("cpu_s", 0.0),
        "first_use_cpu_s": first_cpu,
        "fixed_s": row["wall_s"] - phase,
        "costs": costs,
    }


def fit_graph_model(rows: list[dict]) -> dict:
    """The model of several one-worker runs of the same graph: each beam's cost and every
    other term the median of the runs' own models. One run's first use is a single chunk's
    excess over the rest (0.08-0.22 s in two runs back to back, 2026-11-29), and it is paid
    by every worker of a large cluster: a median over runs does not follow one run's noise."""
    models = [graph_model(r) for r in rows]
    fitted = {
        k: statistics.median(m[k] for m in models) for k in models[0] if k not in ("costs", "beams")
    }
    costs = [statistics.median(c) for c in zip(*(m["costs"] for m in models), strict=True)]
    return {**fitted, "beams": len(costs), "costs": costs, "runs": len(models)}


def predict(model: dict, workers: int, cores: int | None = None) -> dict:
    """The run on ``workers`` workers: the chunks scheduled as dask does, and never faster
    than ``cores`` (the machine's; one a worker when not given) can give the phase's CPU."""
    cores = min(cores or workers, workers)
    chunk = choose_chunk(model["beams"], workers)
    scheduled = makespan(
        model["costs"], model["write_s"], model["gap_s"], workers, chunk, model["first_use_s"]
    )
    cpu = model["phase_cpu_s"] + workers * model["first_use_cpu_s"]
    phase = max(scheduled, cpu / cores)
    return {
        "workers": workers,
        "chunk": chunk,
        "scheduled_s": scheduled,
        "cpu_bound_s": cpu / cores,
        "chunks_s": phase,
        "wall_s": model["fixed_s"] + phase,
    }


def study_model(row: dict) -> dict:
    """The study at one worker: its work (every run's chunk tasks, and the antenna and
    hardware measurements, tasks beside them: wall time), its runs' set-ups (their steps in
    the `pasim` process, one lane beside the workers), the report's figures (tasks too, once
    the runs are done), the rest (start-up, scoring, the report's page: what no run overlaps,
    from the study's start and the runs' records), the CPU that ran beside the work (the
    workers' tasks and the ``pasim`` process's own share: set-up, scoring, the scheduler),
    each run's beams and first use (:func:`leading_excess`: the run's memos, which every
    further worker it reaches fills again), and what starting a worker cost (its process's
    CPU before its first task: imports, warm-up, the first run's inputs; every further worker
    pays it again)."""
    work = row.get("measure_s", 0.0)
    setups = 0.0
    runs = []
    started: dict[str, float] = {}  # worker -> its CPU before its first chunk
    first_chunk: dict[str, float] = {}  # worker -> when its first chunk started (epoch s)
    for r in row["records"]:
        # The set-up steps; not the cluster's connection (shared) nor the chunk phase, whose
        # tasks are counted one by one below.
        setup = [s for s in r["steps"] if s["kind"] not in ("connect", "chunks")]
        setups += sum(s["stop"] - s["start"] for s in setup)
        tasks = sorted(r["tasks"], key=lambda t: t["start"])
        spans = [t["stop"] - t["start"] for t in tasks]
        work += sum(spans)
        first = leading_excess(spans)
        beams = sum(t["beams"][1] - t["beams"][0] for t in tasks if "beams" in t)
        runs.append((beams, first))
        for t in tasks:
            if "worker_cpu_s" in t:  # records from before it: no start-up term
                w = process_of(t["worker"])
                at = r.get("started", 0.0) + t["start"]
                if at < first_chunk.get(w, math.inf):
                    first_chunk[w] = at
                    started[w] = t["worker_cpu_s"]
    # A worker's start is its CPU before its first chunk less the measurements it ran first:
    # those are work, counted above, and sent to one worker each, not paid by every one.
    for m in row.get("measurements", []):
        w = process_of(m["worker"])
        if w in started and m["stop"] <= first_chunk[w]:
            started[w] -= m["cpu_s"]
    figures_s = row.get("figures_s", 0.0)
    began = study_began(row)
    if began is not None and row["records"]:
        # What no run overlaps: before the first run's set-up (start-up, the study's plan,
        # the cluster) and after the last run's last chunk (scores, the report less its
        # figures). The residual below is nil where the runs' set-ups in the `pasim` process
        # overlap the worker's chunks, as they do on one worker.
        first = min(r["started"] for r in row["records"])
        last = max(r["started"] + r["stopped"] for r in row["records"])
        # The figures took the tail's wall spread over the workers (as predicted below), not
        # their seconds end to end: with two workers, 6.8 s of drawing in 3.4 s.
        drawn = figures_s / max(1, min(row.get("workers", 1), row.get("figures", 1) or 1))
        rest = max(first - began, 0.0) + max(began + row["wall_s"] - last - drawn, 0.0)
    else:
        rest = max(row["wall_s"] - max(work, setups) - figures_s, 0.0)
    return {
        "work_s": work,
        "setup_s": setups,
        # The `pasim` process's CPU while the runs ran (set-ups, start-ups of runs, the
        # scheduler and client of a local cluster): one interpreter, a lane of its own.
        "process_s": sum(p["cpu_s"] for p in row.get("process", [])),
        "figures_s": figures_s,
        "figures": row.get("figures", 0),
        "rest_s": rest,
        "beside_cpu_s": max(row["cpu_s"] - rest - figures_s, 0.0),
        "start_cpu_s": statistics.median(started.values()) if started else 0.0,
        "runs": runs,
    }


def process_of(worker: str) -> str:
    """A task's worker process (``host:pid``) without the thread it ran in."""
    return worker.split("/", 1)[0]


def study_began(row: dict) -> float | None:
    """When the study's process started (epoch s): recorded, or for rows written before it
    was, their end (``date``, to the second) less their wall time."""
    if "began" in row:
        return float(row["began"])
    if "date" not in row:
        return None
    ended = calendar.timegm(time.strptime(row["date"], "%Y-%m-%dT%H:%M:%SZ"))
    return ended - row["wall_s"]


def leading_excess(spans: list[float]) -> float:
    """A run's first use on a worker, from its chunks' times in the order one worker ran them:
    what its leading chunks took beyond a typical one (the median of all but the first), up
    to the first typical chunk. Some memos fill over several chunks, not one: the 2 m
    CPPAR's pattern grids, one for each beam offset in a column period, are made by the
    first chunk that needs each (its expected run's chunks on one worker, in order: 1.53,
    0.99, 0.64, 0.63, then 0.08-0.5 s), and each further worker makes them again."""
    if len(spans) < 2:
        return 0.0
    typical, excess = statistics.median(spans[1:]), 0.0
    for span in spans:
        if span <= typical:
            break
        excess += span - typical
    return excess


def first_uses(model: dict, workers: int) -> float:
    """The first uses paid again on ``workers``: each run's on every further worker its
    chunks reach (as many as it has chunks, chosen for that many workers)."""
    extra = 0.0
    for beams, first in model.get("runs", []):
        if beams:
            chunks = -(-beams // choose_chunk(beams, workers))
            extra += (min(workers, chunks) - 1) * first
    return extra


def paid_again(model: dict, workers: int) -> float:
    """The CPU that ``workers`` pay beyond one: the runs' first uses again
    (:func:`first_uses`) and each further worker's start."""
    return first_uses(model, workers) + (workers - 1) * model.get("start_cpu_s", 0.0)


def predict_study(model: dict, workers: int, cores: int | None = None) -> float:
    """Runs overlapped: the rest one after another, the work spread over the workers with the
    first uses they pay again and each further worker's start-up (but never faster than the
    runs' set-ups in the `pasim` process, nor than that process's CPU while the runs ran,
    all of it taken as one lane (its threads share one interpreter; as measured on the row's
    workers: unknown how it grows with more), nor than the cores can give the CPU that runs
    beside it; ``cores``: the machine's, one a worker when not given), then the report's
    figures spread over them."""
    cores = cores or workers
    again = paid_again(model, workers)
    figures = model.get("figures_s", 0.0) / max(1, min(workers, model.get("figures", 1) or 1))
    work = max(
        (model["work_s"] + again) / workers,
        model.get("setup_s", 0.0),
        model.get("process_s", 0.0),
        (model["beside_cpu_s"] + again) / cores,
    )
    return model["rest_s"] + work + figures


def study_busy(model: dict, workers: int) -> float:
    """The share of ``workers`` cores (a core each) busy over the predicted study: the CPU
    measured on one worker, with what further workers pay again (:func:`paid_again`)."""
    cpu = model["rest_s"] + model["figures_s"] + model["beside_cpu_s"] + paid_again(model, workers)
    return cpu / (workers * predict_study(model, workers))


def model_checks(rows: list[dict], case: str, predicted) -> list[dict]:
    """The model's wall time against every measured run of this build's ``case``."""
    out = []
    for r in rows:
        if r["case"] == case and r["build"] == "new":
            wall = predicted(r["workers"])
            out.append(
                {
                    "case": case,
                    "workers": r["workers"],
                    "measured_s": r["wall_s"],
                    "predicted_s": wall,
                    "error": wall / r["wall_s"] - 1,
                }
            )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--graph", default=str(ROOT / "graphs" / "generic_radar.yaml"))
    ap.add_argument("--sector", default="0:360")
    ap.add_argument("--run-args", nargs="*", default=[], help="more `pasim run` options")
    ap.add_argument("--workers", default="1,2", help="worker counts (comma separated)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--study", default=str(ROOT / "graphs" / "paper_study.yaml"))
    ap.add_argument("--study-sector", default="240:270")
    ap.add_argument("--no-study", action="store_true")
    ap.add_argument("--no-graph", action="store_true")
    ap.add_argument("--baseline-pythonpath", help="another build to pair every run with")
    ap.add_argument(
        "--baseline-python",
        help="the interpreter of another venv holding the baseline build (an older checkout"
        " whose block modules the installed entry points would not find)",
    )
    ap.add_argument(
        "--store-dir",
        help="where the runs' stores are written (default: the temporary folder); each graph "
        "run's row records the cost of a file there just before it (file_ms)",
    )
    ap.add_argument("--keep", help="keep each study's folder under DIR/BUILD_wW (report, scores)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "bench_scaling.jsonl"))
    args = ap.parse_args()
    if args.baseline_pythonpath:
        misplaced = foreign_packages(python(args, "baseline"), args.baseline_pythonpath)
        if misplaced:
            print(f"bench_scaling: --baseline-pythonpath {args.baseline_pythonpath}: {misplaced}")
            return 2
    counts = [int(w) for w in args.workers.split(",")]
    builds = [("new", None)] + (
        [("baseline", args.baseline_pythonpath)]
        if args.baseline_pythonpath or args.baseline_python
        else []
    )
    rows: list[dict] = []

    def emit(row: dict) -> None:
        light = {k: v for k, v in row.items() if k not in ("record", "records")}
        light["date"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        if row.get("record"):
            light["tasks"] = len(row["record"]["tasks"])
        print(json.dumps(light), flush=True)
        with open(args.out, "a") as f:
            kept = {k: row[k] for k in ("record", "records") if k in row}
            f.write(json.dumps({**light, **kept}) + "\n")
        rows.append(row)

    for rnd in range(args.repeat):
        order = counts if rnd % 2 == 0 else counts[::-1]
        for w in order:
            for name, path in builds if rnd % 2 == 0 else builds[::-1]:
                if not args.no_graph:
                    emit(graph_run(args, w, name, path))
        if not args.no_study:
            for w in order:
                for name, path in builds if rnd % 2 == 0 else builds[::-1]:
                    emit(study_run(args, w, name, path))

    def med(case: str, build: str, w: int, key: str) -> float | None:
        vals = [
            r[key]
            for r in rows
            if (r["case"], r["build"], r["workers"]) == (case, build, w) and r.get(key) is not None
        ]
        return statistics.median(vals) if vals else None

    summary: dict[str, Any] = {"summary": True, "machine_cores": os.cpu_count()}
    for name, _ in builds:
        for w in counts:
            summary[f"graph_{name}_w{w}_chunks_s"] = med("graph", name, w, "chunks_s")
            summary[f"graph_{name}_w{w}_wall_s"] = med("graph", name, w, "wall_s")
            summary[f"graph_{name}_w{w}_file_ms"] = med("graph", name, w, "file_ms")
            summary[f"study_{name}_w{w}_wall_s"] = med("study", name, w, "wall_s")
            summary[f"study_{name}_w{w}_busy"] = med("study", name, w, "busy")
    ones = [
        r
        for r in rows
        if r["case"] == "graph" and r["build"] == "new" and r["workers"] == 1 and r.get("record")
    ]
    checks = []
    if ones:
        model = fit_graph_model(ones)
        summary["model"] = {k: v for k, v in model.items() if k != "costs"}
        cores = os.cpu_count() or 1
        checks += model_checks(rows, "graph", lambda w: predict(model, w, cores)["wall_s"])
        summary["predicted"] = [predict(model, w) for w in (1, 2, 16, 64, 256, 1000)]
    sones = [r for r in rows if r["case"] == "study" and r["build"] == "new" and r["workers"] == 1]
    if sones:
        smodel = study_model(sones[0])
        summary["study_model"] = smodel
        cores = os.cpu_count() or 1
        checks += model_checks(rows, "study", lambda w: predict_study(smodel, w, cores))
        summary["study_predicted"] = {w: predict_study(smodel, w) for w in (16, 64, 256, 1000)}
        summary["study_predicted_busy"] = {w: study_busy(smodel, w) for w in (16, 64, 256, 1000)}
    summary["checks"] = checks
    digests = {r["digest"] for r in rows if r["case"] == "graph"}
    summary["graph_stores_identical"] = len(digests) == 1 if digests else None
    two = [c for c in checks if c["workers"] == 2]
    summary["two_worker_within_15pct"] = bool(two) and all(abs(c["error"]) <= 0.15 for c in two)
    print(json.dumps(summary, indent=1))
    with open(args.out, "a") as f:
        f.write(json.dumps(summary) + "\n")
    return 0 if summary["two_worker_within_15pct"] or not two else 1


if __name__ == "__main__":
    sys.exit(main())
