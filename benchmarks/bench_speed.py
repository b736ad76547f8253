"""What the runs of a study cost, paired against another build of the code (issue 26).

    python benchmarks/bench_speed.py [--baseline-python /venv-old/bin/python] [--repeat 3]
        [--cases one_beam,quick_start,generic_cov,atd_cov,...] [--json results.jsonl]

Each case is a whole ``pasim run`` process (imports, truth, store, scores), timed from outside
with its CPU time and its own peak memory (``os.wait4``). With ``--baseline-python`` (the
interpreter of an environment where the code before the change is installed, e.g.
``git worktree add /tmp/base <commit>`` and ``pip install --no-deps -e /tmp/base`` into a
venv that sees the same dependencies) every case runs ``--repeat`` times in each build,
alternating new / baseline back to back so that both see the same load, and the ratio of
the medians is printed. Both read this checkout's graph files.

Cases (graph, sector, settings):

- ``one_beam``: generic radar, one beam (280:281), default level
- ``quick_start``: generic radar as the README's quick start runs it
- ``<system>_cov`` / ``<system>_comb``: the paper's systems (generic, atd, cppar10, cppar2) over
  240:330 at ``covariance`` / ``combined``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = {
    "generic": "generic_radar",
    "atd": "atd_radar",
    "cppar10": "cppar10_radar",
    "cppar2": "cppar2_radar",
}


def cases() -> dict[str, list[str]]:
    out = {
        "one_beam": ["generic_radar.yaml", "--sector", "280:281"],
        "quick_start": ["generic_radar.yaml"],
    }
    for key, graph in SYSTEMS.items():
        for level, short in (("covariance", "cov"), ("combined", "comb")):
            out[f"{key}_{short}"] = [
                f"{graph}.yaml",
                *("--sector", "240:330", "--set", f"weather.method={level}"),
            ]
    return out


def run_once(python: str, args: list[str]) -> dict[str, float]:
    """One whole ``pasim run`` with ``python``: wall and CPU seconds, peak memory (MB)."""
    with tempfile.TemporaryDirectory() as tmp:
        graph, *rest = args
        cmd = [python, "-m", "pasim_graph", "run", str(ROOT / "graphs" / graph), *rest]
        cmd += ["--out", str(Path(tmp) / "run.zarr")]
        t0 = time.perf_counter()
        with tempfile.TemporaryFile() as err:
            child = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, cwd=tmp)
            _, status, usage = os.wait4(child.pid, 0)
            wall = time.perf_counter() - t0
            if os.waitstatus_to_exitcode(status) != 0:
                err.seek(0)
                raise SystemExit(
                    f"{python}: pasim run {' '.join(args)} failed:\n{err.read().decode()}"
                )
    return {
        "seconds": wall,
        "cpu_seconds": usage.ru_utime + usage.ru_stime,
        "peak_mb": usage.ru_maxrss / 1024,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline-python", help="interpreter of the build to compare against")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", default="one_beam,quick_start,generic_cov,atd_cov")
    ap.add_argument("--json", type=Path, help="append one JSON line per case here")
    args = ap.parse_args()
    known = cases()
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise SystemExit(f"unknown cases {unknown}; known: {', '.join(known)}")
    builds = {"new": sys.executable}
    if args.baseline_python:
        builds["baseline"] = args.baseline_python
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores"
    print(f"| case | build | median s | cpu s | peak MB | ratio |  ({machine}, {time.ctime()})")
    for name in names:
        got: dict[str, list[dict[str, float]]] = {b: [] for b in builds}
        for _ in range(args.repeat):
            for build, python in builds.items():  # back to back: both see the same load
                got[build].append(run_once(python, known[name]))
        medians = {
            b: {k: statistics.median(r[k] for r in rows) for k in rows[0]}
            for b, rows in got.items()
        }
        for build, m in medians.items():
            ratio = ""
            if build == "new" and "baseline" in medians:
                ratio = f"{m['seconds'] / medians['baseline']['seconds']:.2f}"
            print(
                f"| {name} | {build} | {m['seconds']:.2f} | {m['cpu_seconds']:.2f} | "
                f"{m['peak_mb']:.0f} | {ratio} |",
                flush=True,
            )
        if args.json:
            with open(args.json, "a") as f:
                record = {"case": name, "machine": machine, "date": time.strftime("%F")}
                f.write(json.dumps(record | {"runs": got, "median": medians}) + "\n")


if __name__ == "__main__":
    main()
