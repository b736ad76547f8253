"""The figure of docs/scaling.md's network-day estimate, from bench_network_day.py's lines.

    python benchmarks/network_day_figure.py [RESULTS.jsonl] [--out docs/scaling_network_day.png]

Left: each VCP 212 rotation's measured CPU seconds per beam against its gates x pulses, with
the straight-line fit, per method. Right: the bytes a beam of each rotation takes on disk.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument(
        "results",
        nargs="?",
        type=Path,
        default=ROOT / "benchmarks" / "results" / "bench_network_day_2026-11-28.jsonl",
    )
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "scaling_network_day.png")
    args = p.parse_args()
    lines, seen = [], set()
    for text in args.results.read_text().splitlines():
        line = json.loads(text)
        if text and line["method"] not in seen:  # the first measurement of each method
            seen.add(line["method"])
            lines.append(line)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for line, colour in zip(lines, ["tab:blue", "tab:orange"], strict=False):
        rows = line["rotations"]
        gp = np.array([r["gates"] * r["pulses"] for r in rows], float)
        cost = np.array([r["cpu_per_beam_s"] for r in rows])
        ax.plot(gp / 1e3, cost, "o", color=colour, label=f"{line['method']} (measured)")
        x = np.linspace(0, gp.max() * 1.05, 50)
        fit = line["per_beam_s"] + line["per_gate_pulse_s"] * x
        ax.plot(x / 1e3, fit, "-", color=colour, lw=1, label=f"{line['method']} (fit)")
    ax.set_xlabel("gates x pulses of the rotation (thousands)")
    ax.set_ylabel("CPU s per beam (task thread)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title("VCP 212, 3 beams a rotation")
    rows = lines[0]["rotations"]
    el = [f"{r['elevation_deg']:g}" for r in rows]
    disk = [r["disk_bytes_per_beam"] / 1e3 for r in rows]
    bx.bar(range(len(rows)), disk, color="tab:gray")
    bx.set_xticks(range(len(rows)), el, rotation=90, fontsize=7)
    bx.set_xlabel("rotation (elevation, deg; split cuts twice)")
    bx.set_ylabel("KB per beam on disk (compressed)")
    bx.set_title(f"{lines[0]['machine']}, {lines[0]['date']}", fontsize=9)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
