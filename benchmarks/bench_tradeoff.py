"""Speed against accuracy, measured (run by hand, not in CI; docs/tradeoff.md quotes it).

    python benchmarks/bench_tradeoff.py --truth ../shared/data/KLBB20160601_150025_V06 \
        [--sector 280:300] [--graphs generic_radar cppar10_radar] [--levels ...] [--plot PNG]

For each graph: `pasim tradeoff --json` on the sector (every level in a fresh process), the
floor of design-notes section 6 measured on this machine (normal deviates per second, length-2M
FFTs per second) and the combined level's ratio to it, and `pasim run --outputs DBZH` against a
full run (same seed, same store contents for DBZH). Prints JSON lines; with --plot draws the std
of each moment against the weather channel's seconds, one panel per moment.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.fft

ROOT = Path(__file__).resolve().parents[1]


def pasim(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pasim_graph", *args], capture_output=True, text=True, check=True
    )


def floor_rates(pulses: int) -> dict[str, float]:
    """Normal deviates (float32) and length-2M complex64 FFTs per second, one thread."""
    gen = np.random.default_rng(0)
    t = time.perf_counter()
    for _ in range(10):
        gen.standard_normal(10_000_000, dtype=np.float32)
    normals = 1e8 / (time.perf_counter() - t)
    x = np.ones((4096, 2 * pulses), np.complex64)
    t = time.perf_counter()
    for _ in range(20):
        scipy.fft.ifft(x, axis=-1)
    ffts = 20 * 4096 / (time.perf_counter() - t)
    return {"normals_per_s": normals, "ffts_per_s": ffts}


def combined_floor(graph: str, truth: str, sector: str, pulses: int) -> dict[str, float]:
    """Deviates and FFTs the combined level must draw on this sector, and their time."""
    from pasim_graph import load
    from pasim_graph.executor import LocalExecutor, RunOptions

    a0, a1 = (float(x) for x in sector.split(":"))
    g = load(
        graph,
        {
            "truth.path": truth,
            "scan.azimuth_start_deg": a0,
            "scan.azimuth_stop_deg": a1,
            "weather.method": "expected",
        },
    )
    ex = LocalExecutor(g, RunOptions(chunk_beams=10_000))
    sweep = ex.run()
    # Gates the combined level draws: those with any echo power within the pattern support.
    drawn = int((sweep["SNRH"].values > -np.inf).sum())
    rates = floor_rates(pulses)
    normals = drawn * 2 * (2 * pulses) * 2  # H and V, 2M bins, real and imaginary
    seconds = normals / rates["normals_per_s"] + drawn * 2 / rates["ffts_per_s"]
    return {"gates_drawn": drawn, "normals": normals, "floor_seconds": seconds, **rates}


def outputs_speed(graph: str, truth: str, sector: str) -> dict[str, float]:
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, extra in (("full", []), ("DBZH", ["--outputs", "DBZH"])):
            t = time.perf_counter()
            pasim(
                "run", graph, "--truth", truth, "--sector", sector, "--out",
                str(Path(tmp) / f"{label}.zarr"), *extra,
            )  # fmt: skip
            out[f"seconds_{label}"] = time.perf_counter() - t
        import xarray as xr

        a = xr.open_datatree(Path(tmp) / "full.zarr", engine="zarr")["sweep_0"]["DBZH"].values
        b = xr.open_datatree(Path(tmp) / "DBZH.zarr", engine="zarr")["sweep_0"]["DBZH"].values
        out["same_dbzh"] = bool(np.array_equal(a, b, equal_nan=True))
    return out


def plot(results: dict[str, list[dict]], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    moments = ["DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"]
    fig, axes = plt.subplots(2, 3, figsize=(12, 7))
    for ax, m in zip(axes.flat, moments, strict=True):
        for k, (name, rows) in enumerate(results.items()):
            t = [r["seconds_weather"] for r in rows]
            s = [r["std"].get(m) for r in rows]
            ax.plot(t, s, "o-", label=name)
            if k == 0:  # level names once per panel, on the first series
                for r, x, y in zip(rows, t, s, strict=True):
                    ax.annotate(r["level"], (x, y), fontsize=6, rotation=30)
        ax.set_xscale("log")
        ax.set_xlabel("weather channel seconds")
        ax.set_ylabel(f"std of {m} error against truth")
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--truth")
    ap.add_argument("--sector", default="280:300")
    ap.add_argument("--graphs", nargs="+", default=["generic_radar", "cppar10_radar"])
    ap.add_argument("--levels", default=None)
    ap.add_argument("--plot", default=None)
    ap.add_argument("--skip-outputs", action="store_true")
    ap.add_argument(
        "--plot-from", nargs="+", metavar="JSONL", help="only plot earlier runs' printed lines"
    )
    args = ap.parse_args()
    results: dict[str, list[dict]] = {}
    if args.plot_from:
        for path in args.plot_from:
            for line in Path(path).read_text().splitlines():
                row = json.loads(line)
                if "level" in row:
                    results.setdefault(f"{row['graph']} {row['sector']}", []).append(row)
        plot(results, args.plot or "tradeoff.png")
        return
    for name in args.graphs:
        graph = str(ROOT / "graphs" / f"{name}.yaml")
        extra = ["--levels", args.levels] if args.levels else []
        res = pasim(
            "tradeoff", graph, "--truth", args.truth, "--sector", args.sector, "--json", *extra
        )
        rows = json.loads(res.stdout)
        results[name] = rows
        for r in rows:
            print(json.dumps({"graph": name, "sector": args.sector, **r}))
        fl = combined_floor(graph, args.truth, args.sector, 64)
        by_level = {r["level"]: r for r in rows}
        if "combined" in by_level:
            fl["combined_over_floor"] = (
                by_level["combined"]["seconds_weather"] / fl["floor_seconds"]
            )
        if "combined" in by_level and "covariance" in by_level:
            fl["covariance_over_combined"] = (
                by_level["covariance"]["seconds_weather"] / by_level["combined"]["seconds_weather"]
            )
        print(json.dumps({"graph": name, "sector": args.sector, "floor": fl}))
        if not args.skip_outputs:
            print(json.dumps({"graph": name, "sector": args.sector, "outputs": outputs_speed(
                graph, args.truth, args.sector)}))  # fmt: skip
    if args.plot:
        plot(results, args.plot)


if __name__ == "__main__":
    main()
