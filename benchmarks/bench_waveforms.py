"""Waveforms on real weather: errors, range-sidelobe contamination and cost (run by hand).

    python benchmarks/bench_waveforms.py --truth ../shared/data/KLBB20160601_150025_V06 \
        [--sector 240:330] [--graphs generic_radar waveform_lfm waveform_taylor_lfm \
        waveform_nlfm] [--levels expected combined covariance] [--seeds 0 1 2] \
        [--repeat 3] [--out benchmarks/results/waveforms_240-330.jsonl] [--plots docs]

Every run is in this process, one after another, on one BLAS thread, chunks of 8 beams, so
that the timing ratios are measured back to back on the same machine state (best of
``--repeat``). Prints and writes JSON lines:

- ``kind: errors``: per graph, level and seed, bias and std of every moment against the raw
  truth on the scorer's gates, and DBZH on the gates every graph scores (``common``);
- ``kind: contamination``: DBZH bias against truth reflectivity bins on the common gates, and
  on the gates behind a strong core (truth below 30 dBZ within one pulse length beyond a gate
  of 50 dBZ or more on the same ray);
- ``kind: range_error`` and ``range_contamination`` (expected level): each graph's DBZH minus
  that of ``--reference`` run with a one-sample pulse (no range smoothing, same pulse energy),
  i.e. what the range response alone (mainlobe and sidelobes) does, overall and by bins;
- ``kind: timing``: the weather channel's seconds per graph and level, best of ``--repeat``,
  and their ratio to the first graph's.

With ``--plots DIR`` draws DIR/waveforms_weather_bias.png (bias against truth reflectivity)
and DIR/waveforms_weather_ray.png (a ray through the convective line, every graph at the
expected level).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MOMENTS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
BINS = np.arange(10.0, 65.0, 5.0)


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def run(
    graph: str, truth: str, sector: str, level: str, seed: int, extra: dict | None = None
) -> dict:
    """One in-process run: the sweep's fields as arrays, and the weather channel's seconds."""
    from pasim_graph import load
    from pasim_graph.executor import LocalExecutor, RunOptions

    a0, a1 = (float(x) for x in sector.split(":"))
    g = load(
        ROOT / "graphs" / f"{graph}.yaml",
        {
            "truth.path": truth,
            "scan.azimuth_start_deg": a0,
            "scan.azimuth_stop_deg": a1,
            "weather.method": level,
            **(extra or {}),
        },
    )
    ex = LocalExecutor(g, RunOptions(seed=seed, chunk_beams=8))
    ex.load()
    t = time.perf_counter()
    sweep = ex.run()
    seconds = time.perf_counter() - t
    fields = {k: sweep[k].values for k in sweep.data_vars if sweep[k].dims[-1:] == ("range",)}
    return {
        "fields": fields,
        "range": sweep["range"].values,
        "blind_range_m": float(sweep.attrs["blind_range_m"]),
        "seconds_weather": ex.block_seconds["weather"],
        "seconds_run": seconds,
    }


def errors(res: dict) -> dict:
    f = res["fields"]
    out = {}
    for m in MOMENTS:
        e = f.get(f"error_{m}")
        if e is None:
            continue
        e = e[np.isfinite(e)]
        out[m] = {"bias": float(e.mean()), "std": float(e.std(ddof=1)), "count": int(e.size)}
    return out


def behind_cores(truth: np.ndarray, rng: np.ndarray, reach_m: float) -> np.ndarray:
    """Gates of truth below 30 dBZ within ``reach_m`` beyond a gate of 50 dBZ or more."""
    strong = np.nan_to_num(truth, nan=-99.0) >= 50.0
    step = float(np.median(np.diff(rng)))
    k = round(reach_m / step)
    seen = np.zeros_like(strong)
    # A gate is behind a core if a strong gate lies 1..k gates nearer on its ray.
    for d in range(1, k + 1):
        seen[:, d:] |= strong[:, :-d]
    return seen & (np.nan_to_num(truth, nan=99.0) < 30.0)


def contamination(res: dict, common: np.ndarray, reach_m: float) -> dict:
    f = res["fields"]
    truth, err = f["truth_DBZH"], f["error_DBZH"]
    out = {"bins": BINS.tolist(), "bias": [], "count": []}
    for lo in BINS:
        sel = common & (truth >= lo) & (truth < lo + 5) & np.isfinite(err)
        out["bias"].append(float(err[sel].mean()) if sel.any() else None)
        out["count"].append(int(sel.sum()))
    behind = behind_cores(truth, res["range"], reach_m) & np.isfinite(err) & common
    out["behind_core_bias"] = float(err[behind].mean()) if behind.any() else None
    out["behind_core_count"] = int(behind.sum())
    return out


def plot(results: dict, path_dir: str, level: str, ray_beam: int | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    graphs = list(results)
    panels = [("contamination", "against the raw truth")]
    if "range_contamination" in results[graphs[0]]:
        panels.append(("range_contamination", "against a one-sample pulse (range response only)"))
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 4.5), squeeze=False)
    for ax, (key, what) in zip(axes[0], panels, strict=True):
        for g in graphs:
            c = results[g][key]
            x = np.array(c["bins"]) + 2.5
            y = np.array([np.nan if b is None else b for b in c["bias"]])
            ax.plot(x, y, "o-", label=g)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel("truth DBZH (dBZ, 5 dB bins)")
        ax.set_ylabel(f"mean DBZH difference (dB), {level} level")
        ax.set_title(f"DBZH bias {what}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("gates scored by every graph", fontsize=9)
    fig.tight_layout()
    fig.savefig(Path(path_dir) / "waveforms_weather_bias.png", dpi=90)

    first = results[graphs[0]]
    truth = first["fields"]["truth_DBZH"]
    rng_km = first["range"] / 1e3
    reach = max(r["blind_range_m"] for r in results.values())
    # A core beyond the blind range (cores inside it contaminate too, but the figure is about
    # a convective line seen whole).
    visible = np.where((first["range"] > reach)[None, :], truth, np.nan)
    behind = behind_cores(visible, first["range"], reach)
    if ray_beam is None:
        ray_beam = int(np.argmax(behind.sum(axis=1)))
    # The core whose shadow holds the most of those gates, and 10 km before to 15 km after it.
    gates = np.flatnonzero(behind[ray_beam])
    strong = np.flatnonzero(np.nan_to_num(visible[ray_beam], nan=-99) >= 50)
    if gates.size:
        core = int(strong[strong < gates.min()].max())
    else:
        core = int(np.nanargmax(truth[ray_beam]))
    window = slice(max(0, core - 40), min(rng_km.size, core + 60))
    fig, ax = plt.subplots(figsize=(9, 4.5))
    ax.plot(rng_km[window], truth[ray_beam, window], "k-", lw=2, label="truth (raw NEXRAD)")
    for g in graphs:
        ax.plot(rng_km[window], results[g]["fields"]["DBZH"][ray_beam, window], lw=1, label=g)
    ax.set_xlabel("range (km)")
    ax.set_ylabel("DBZH (dBZ)")
    ax.set_title(f"beam {ray_beam}: DBZH along a ray through the convective line ({level} level)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(Path(path_dir) / "waveforms_weather_ray.png", dpi=90)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--truth", required=True)
    ap.add_argument("--sector", default="240:330")
    ap.add_argument(
        "--graphs",
        nargs="+",
        default=["generic_radar", "waveform_lfm", "waveform_taylor_lfm", "waveform_nlfm"],
    )
    ap.add_argument("--levels", nargs="*", default=["expected", "combined", "covariance"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0])
    ap.add_argument("--repeat", type=int, default=3, help="timing runs per graph (best of)")
    ap.add_argument("--timing-levels", nargs="*", default=["combined"])
    ap.add_argument("--out", default=None)
    ap.add_argument("--plots", default=None)
    ap.add_argument("--plot-level", default="expected")
    ap.add_argument(
        "--reference",
        default="generic_radar",
        help="graph run at the expected level with a one-sample pulse (no range smoothing): "
        "the range response's own error is each graph's expected DBZH minus this one's",
    )
    args = ap.parse_args()
    out = open(args.out, "w") if args.out else None

    def emit(row: dict) -> None:
        line = json.dumps(row)
        print(line, flush=True)
        if out:
            out.write(line + "\n")
            out.flush()

    emit(
        {
            "kind": "machine",
            "date": time.strftime("%Y-%m-%d"),
            "machine": cpu_model(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
        }
    )
    for level in args.levels:
        for seed in args.seeds if level != "expected" else args.seeds[:1]:
            runs = {g: run(g, args.truth, args.sector, level, seed) for g in args.graphs}
            scored = [np.isfinite(r["fields"]["error_DBZH"]) for r in runs.values()]
            common = np.logical_and.reduce(scored)
            reach = max(r["blind_range_m"] for r in runs.values())
            for g, r in runs.items():
                e = r["fields"]["error_DBZH"][common]
                emit(
                    {
                        "kind": "errors",
                        "graph": g,
                        "level": level,
                        "seed": seed,
                        "sector": args.sector,
                        "seconds_weather": r["seconds_weather"],
                        "moments": errors(r),
                        "common": {
                            "DBZH_bias": float(e.mean()),
                            "DBZH_std": float(e.std(ddof=1)),
                            "count": int(e.size),
                        },
                    }
                )
                r["contamination"] = contamination(r, common, reach)
                emit(
                    {
                        "kind": "contamination",
                        "graph": g,
                        "level": level,
                        "seed": seed,
                        "reach_m": reach,
                        **r["contamination"],
                    }
                )
            if level == "expected" and args.reference:
                # One sample at 20 MHz, with the pulse energy of the 1.6 us pulse (same SNR).
                one_sample = {"tx.width_s": 5e-8, "weather.peak_power_w": 22.4e6}
                ref = run(args.reference, args.truth, args.sector, level, seed, one_sample)
                for g, r in runs.items():
                    diff = r["fields"]["DBZH"] - ref["fields"]["DBZH"]
                    d = diff[common & np.isfinite(diff)]
                    emit(
                        {
                            "kind": "range_error",
                            "graph": g,
                            "level": level,
                            "reference": f"{args.reference} with a one-sample pulse",
                            "DBZH_bias": float(d.mean()),
                            "DBZH_std": float(d.std(ddof=1)),
                            "count": int(d.size),
                        }
                    )
                    shifted = dict(r, fields={**r["fields"], "error_DBZH": diff})
                    r["range_contamination"] = contamination(shifted, common, reach)
                    emit(
                        {
                            "kind": "range_contamination",
                            "graph": g,
                            "level": level,
                            **r["range_contamination"],
                        }
                    )
            if args.plots and level == args.plot_level and seed == args.seeds[0]:
                plot(runs, args.plots, level)
    for level in args.timing_levels:
        best = {g: float("inf") for g in args.graphs}
        for _ in range(args.repeat):
            for g in args.graphs:
                best[g] = min(best[g], run(g, args.truth, args.sector, level, 0)["seconds_weather"])
        base = best[args.graphs[0]]
        for g in args.graphs:
            emit(
                {
                    "kind": "timing",
                    "graph": g,
                    "level": level,
                    "seconds_weather_best": best[g],
                    "ratio_to_first": best[g] / base,
                    "repeat": args.repeat,
                }
            )


if __name__ == "__main__":
    main()
