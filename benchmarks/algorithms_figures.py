"""The pictures and numbers of docs/algorithms.md, from two runs of the bundled storm:

    python benchmarks/algorithms_figures.py [WORKDIR]

runs graphs/dealias_cband.yaml (C band, PRT 2 ms) and graphs/algorithms_cband.yaml (C band,
PRT 1 ms, every algorithm block) into WORKDIR (default ./algorithms-runs; kept, so a second
call only draws) and writes docs/algorithms_dealias.png, algorithms_zphi.png and
algorithms_kdp.png, printing the numbers the page quotes.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MAX_RANGE_KM = 150.0


def run(graph: str, out: Path) -> xr.Dataset:
    if not out.exists():
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pasim_graph",
                "run",
                str(ROOT / "graphs" / graph),
                "--out",
                str(out),
            ],
            check=True,
        )
    return xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()


def within(d: np.ndarray, t: np.ndarray, mask: np.ndarray, tol: float = 2.0) -> float:
    m = mask & np.isfinite(d) & np.isfinite(t)
    return float(np.mean(np.abs(d[m] - t[m]) <= tol))


def dealias_numbers(s: xr.Dataset, name: str) -> dict[str, float]:
    """Fractions of scored gates (estimate and truth finite) within 2 m/s of the truth."""
    v, t, d = (s[k].values.astype(np.float64) for k in ("VRADH", "truth_VRADH", name))
    scored = s["scored"].values.astype(bool) & np.isfinite(v) & np.isfinite(t)
    nyquist = float(s["nyquist_velocity"].values[0])
    folded = scored & (np.abs(t) > nyquist)
    return {
        "nyquist": nyquist,
        "gates": int(scored.sum()),
        "before": within(v, t, scored),
        "after": within(d, t, scored),
        "folded": int(folded.sum()),
        "folded_before": within(v, t, folded),
        "folded_after": within(d, t, folded),
    }


def ppi(ax, s: xr.Dataset, values: np.ndarray, title: str, **kw) -> None:
    az = np.deg2rad(s["azimuth"].values)
    r = s["range"].values / 1e3
    keep = r <= MAX_RANGE_KM
    x = r[None, keep] * np.sin(az[:, None])
    y = r[None, keep] * np.cos(az[:, None])
    mesh = ax.pcolormesh(x, y, values[:, keep], shading="nearest", **kw)
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlabel("east (km)", fontsize=8)
    plt.colorbar(mesh, ax=ax, shrink=0.8)


def dealias_figure(s: xr.Dataset) -> None:
    ny = float(s["nyquist_velocity"].values[0])
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6))
    kw = {"cmap": "RdBu_r", "vmin": -20, "vmax": 20}
    ppi(axes[0], s, s["truth_VRADH"].values, "truth velocity (KLBB, m/s)", **kw)
    ppi(axes[1], s, s["VRADH"].values, f"estimated, folded at +-{ny:.1f} m/s", **kw)
    ppi(axes[2], s, s["VRADH_DEALIASED_REGION"].values, "dealiased (Py-ART region-based)", **kw)
    axes[0].set_ylabel("north (km)", fontsize=8)
    fig.suptitle("C band, PRT 2 ms (graphs/dealias_cband.yaml)", fontsize=10)
    fig.tight_layout()
    fig.savefig(DOCS / "algorithms_dealias.png", dpi=90)
    plt.close(fig)


def zphi_figure(s: xr.Dataset) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6))
    kw = {"cmap": "RdBu_r", "vmin": -10, "vmax": 10}
    truth = s["truth_DBZH"].values
    ppi(axes[0], s, s["truth_DBZH"].values, "truth Z (dBZ)", cmap="viridis", vmin=0, vmax=65)
    ppi(axes[1], s, s["DBZH"].values - truth, "estimated Z - truth (attenuated, dB)", **kw)
    ppi(axes[2], s, s["DBZH_ZPHI"].values - truth, "Z-PHI corrected Z - truth (dB)", **kw)
    axes[0].set_ylabel("north (km)", fontsize=8)
    fig.suptitle("C band through the KLBB squall line (graphs/algorithms_cband.yaml)", fontsize=10)
    fig.tight_layout()
    fig.savefig(DOCS / "algorithms_zphi.png", dpi=90)
    plt.close(fig)


def kdp_figure(s: xr.Dataset) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6))
    kw = {"cmap": "magma_r", "vmin": -0.5, "vmax": 4}
    ppi(
        axes[0],
        s,
        s["ideal_KDP_VULPIANI"].values,
        "ideal: Vulpiani on the truth's PHIDP x f/f_t",
        **kw,
    )
    ppi(axes[1], s, s["KDP_VULPIANI"].values, "Vulpiani on the estimated PHIDP (deg/km)", **kw)
    ppi(axes[2], s, s["KDP_MAESAKA"].values, "Maesaka on the estimated PHIDP (deg/km)", **kw)
    axes[0].set_ylabel("north (km)", fontsize=8)
    fig.tight_layout()
    fig.savefig(DOCS / "algorithms_kdp.png", dpi=90)
    plt.close(fig)


def main() -> None:
    work = Path(sys.argv[1] if len(sys.argv) > 1 else "algorithms-runs")
    work.mkdir(exist_ok=True)
    dealias = run("dealias_cband.yaml", work / "dealias.zarr")
    algos = run("algorithms_cband.yaml", work / "algorithms.zarr")
    print("PRT 2 ms, region:", dealias_numbers(dealias, "VRADH_DEALIASED_REGION"))
    print("PRT 1 ms, region:", dealias_numbers(algos, "VRADH_DEALIASED_REGION"))
    for name in ("DBZH", "DBZH_ZPHI", "KDP_VULPIANI", "KDP_MAESAKA", "RATE_Z", "RATE_KDP"):
        error = algos[f"error_{name}"].values
        print(f"{name}: bias {np.nanmean(error):.4f}, std {np.nanstd(error, ddof=1):.4f}")
    dealias_figure(dealias)
    zphi_figure(algos)
    kdp_figure(algos)


if __name__ == "__main__":
    main()
