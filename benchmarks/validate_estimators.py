"""Estimator statistics of the simulator against theory, on the uniform scene (issue 3).

    python benchmarks/validate_estimators.py [--methods covariance monte_carlo] [--out FILE]

For every point of the grid M in {32, 128}, width in {2, 4} m/s, SNR in {10, 30} dB, rho_hv in
{0.9, 0.98} (PRT 1 ms, 2.8 GHz, 30 dBZ, ZDR 1 dB, phi_DP 30 deg, 5 m/s) it runs
`pasim run graphs/uniform_ideal.yaml` with those settings, reads `pasim score --json`, and
compares each moment's bias and std with `tests.reference.theory.estimator_statistics` (exact
Gaussian moments + delta method). Prints Markdown tables and writes the rows as JSON.
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GRAPH = ROOT / "graphs" / "uniform_ideal.yaml"
MOMENTS = ("DBZH", "VRADH", "WRADH", "ZDR", "RHOHV", "PHIDP")
FIXED = {
    "prt_s": 1e-3,
    "wavelength_m": 299_792_458.0 / 2.8e9,
    "velocity_ms": 5.0,
    "zdr_db": 1.0,
    "phidp_deg": 30.0,
}
REFERENCE_DWELLS = 20_000
GRID = list(itertools.product((32, 128), (2.0, 4.0), (10.0, 30.0), (0.9, 0.98)))


def run_point(pulses, width, snr, rho, method, seed=0):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.zarr"
        sets = {
            "scan.pulses": pulses,
            "scan.prt_s": FIXED["prt_s"],
            "scene.spectrum_width_ms": width,
            "receiver.snr_db": snr,
            "scene.cross_correlation_ratio": rho,
            "weather.method": method,
        }
        cmd = [
            sys.executable,
            "-m",
            "pasim_graph",
            "run",
            str(GRAPH),
            "--seed",
            str(seed),
            "--out",
            str(out),
        ]
        for k, v in sets.items():
            cmd += ["--set", f"{k}={v}"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        seconds = time.perf_counter() - t0
        score = json.loads(
            subprocess.run(
                [sys.executable, "-m", "pasim_graph", "score", str(out), "--json"],
                check=True,
                capture_output=True,
                text=True,
            ).stdout
        )
    return score, seconds


def main() -> None:
    sys.path.insert(0, str(ROOT))  # the reference theory sits beside the tests
    from tests.reference.theory import (
        compare_with_reference,
        estimator_statistics,
        monte_carlo_statistics,
    )

    ap = argparse.ArgumentParser()
    ap.add_argument("--methods", nargs="+", default=["covariance", "monte_carlo"])
    ap.add_argument("--out", default="validation.json")
    ap.add_argument("--from-json", help="re-judge and print the rows of an earlier run")
    args = ap.parse_args()
    results = json.loads(Path(args.from_json).read_text()) if args.from_json else []
    for r in results:  # re-judge with the current rule and theory
        point = (
            r["pulses"],
            FIXED["prt_s"],
            FIXED["wavelength_m"],
            r["width_ms"],
            FIXED["velocity_ms"],
            r["snr_db"],
            FIXED["zdr_db"],
            r["rho_hv"],
            FIXED["phidp_deg"],
        )
        score = {
            n: {"std": m["std"], "bias": m["bias"], "count": m["count"]}
            for n, m in r["moments"].items()
        }
        reference = {
            n: (
                m.get("bias_reference", m.get("bias_theory")),
                m.get("std_reference", m.get("std_theory")),
            )
            for n, m in r["moments"].items()
        }
        r["moments"] = compare_with_reference(
            score, reference, estimator_statistics(*point), REFERENCE_DWELLS
        )
    for method in [] if args.from_json else args.methods:
        for pulses, width, snr, rho in GRID:
            point = (
                pulses,
                FIXED["prt_s"],
                FIXED["wavelength_m"],
                width,
                FIXED["velocity_ms"],
                snr,
                FIXED["zdr_db"],
                rho,
                FIXED["phidp_deg"],
            )
            theory = estimator_statistics(*point)
            reference = monte_carlo_statistics(*point, gates=REFERENCE_DWELLS, seed=1)
            score, seconds = run_point(pulses, width, snr, rho, method)
            rows = compare_with_reference(score, reference, theory, REFERENCE_DWELLS)
            gates = score["DBZH"]["scored_gates"]
            results.append(
                {
                    "method": method,
                    "pulses": pulses,
                    "width_ms": width,
                    "snr_db": snr,
                    "rho_hv": rho,
                    "seconds": seconds,
                    "gates": gates,
                    "moments": rows,
                }
            )
            bad = [
                f"{n} std {r['std']:.3g} vs {r['std_theory']:.3g}, bias {r['bias']:+.3g} vs "
                f"{r['bias_theory']:+.3g}"
                for n, r in rows.items()
                if not r["ok"]
            ]
            flag = "ok" if not bad else "OUT: " + "; ".join(bad)
            print(
                f"{method} M={pulses} w={width} snr={snr} rho={rho}: {seconds:.1f} s {flag}",
                file=sys.stderr,
                flush=True,
            )
    Path(args.out).write_text(json.dumps(results, indent=1))
    args.methods = sorted({r["method"] for r in results}, key=["covariance", "monte_carlo"].index)
    for method in args.methods:
        print(f"\n### {method}: std simulated / reference [theory] (bias simulated, reference)\n")
        print("| M | width | SNR | rho | " + " | ".join(MOMENTS) + " | s |")
        print("|---" * (len(MOMENTS) + 5) + "|")
        for r in (r for r in results if r["method"] == method):
            cells = []
            for name in MOMENTS:
                m = r["moments"][name]
                mark = "" if m["ok"] else " **x**"
                cells.append(
                    f"{m['std']:.3g} / {m['std_reference']:.3g} [{m['std_theory']:.3g}] "
                    f"({m['bias']:+.2g}, {m['bias_reference']:+.2g}){mark}"
                )
            print(
                f"| {r['pulses']} | {r['width_ms']:g} | {r['snr_db']:g} | {r['rho_hv']:g} | "
                + " | ".join(cells)
                + f" | {r['seconds']:.1f} |"
            )
    if len(args.methods) > 1:
        print("\n### Monte Carlo std / covariance std\n")
        print("| M | width | SNR | rho | " + " | ".join(MOMENTS) + " |")
        print("|---" * (len(MOMENTS) + 4) + "|")
        cov = [r for r in results if r["method"] == "covariance"]
        mc = [r for r in results if r["method"] == "monte_carlo"]
        for a, b in zip(cov, mc, strict=True):
            ratios = [b["moments"][n]["std"] / a["moments"][n]["std"] for n in MOMENTS]
            print(
                f"| {a['pulses']} | {a['width_ms']:g} | {a['snr_db']:g} | {a['rho_hv']:g} | "
                + " | ".join(f"{x:.3f}" for x in ratios)
                + " |"
            )


if __name__ == "__main__":
    main()
