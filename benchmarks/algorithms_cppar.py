"""The Z-PHI and KDP numbers and picture of docs/algorithms.md on the 10 m CPPAR at C band:

    python benchmarks/algorithms_cppar.py [WORKDIR]

runs graphs/zphi_cppar10_cband.yaml (seed 0) with Z-PHI's alpha from the propagation path
and from Py-ART, with the gases off, at the expected level (no estimator noise) with the
path on and off, and with Z-PHI's rho_hv gate filter at 0.8; graphs/algorithms_cband.yaml
(the generic radar) with the path's alpha, without and with the filter; then
graphs/algorithms_cband.yaml on 297-303 deg with Schneebeli's KDP beside Maesaka's. Runs
are kept in WORKDIR (default ./algorithms-cppar-runs), so a second call only measures and
draws; writes docs/algorithms_zphi_cppar.png and prints the numbers.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.colors import LogNorm

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GRAPH = ROOT / "graphs" / "zphi_cppar10_cband.yaml"
MAX_RANGE_KM = 150.0
RUNS = {
    "propagation": (GRAPH, []),
    "pyart": (GRAPH, ["--set", "zphi.coefficients=pyart"]),
    "no_gases": (GRAPH, ["--set", "weather.gaseous_attenuation=false"]),
    "expected_on": (
        GRAPH,
        ["--set", "weather.gaseous_attenuation=false", "--set", "weather.method=expected"],
    ),
    "expected_off": (
        GRAPH,
        ["--set", "weather.propagation=off", "--set", "weather.method=expected"],
    ),
    "rhohv08": (GRAPH, ["--set", "zphi.min_rhohv=0.8"]),
    "expected_on_rhohv08": (
        GRAPH,
        [
            "--set",
            "zphi.min_rhohv=0.8",
            "--set",
            "weather.gaseous_attenuation=false",
            "--set",
            "weather.method=expected",
        ],
    ),
    "generic_propagation": (
        ROOT / "graphs" / "algorithms_cband.yaml",
        ["--set", "zphi.coefficients=propagation"],
    ),
    "generic_rhohv08": (
        ROOT / "graphs" / "algorithms_cband.yaml",
        ["--set", "zphi.coefficients=propagation", "--set", "zphi.min_rhohv=0.8"],
    ),
    "schneebeli": (
        ROOT / "graphs" / "algorithms_cband.yaml",
        ["--sector", "297:303", "--set", "kdp.method=schneebeli"],
    ),
}


def run(work: Path, name: str) -> xr.Dataset:
    out = work / f"{name}.zarr"
    graph, more = RUNS[name]
    if not out.exists():
        t0 = time.time()
        cmd = [sys.executable, "-m", "pasim_graph", "run", str(graph), "--out", str(out), *more]
        subprocess.run(cmd, check=True)
        print(f"{name}: {time.time() - t0:.0f} s")
    return xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()


def scored(s: xr.Dataset, name: str) -> str:
    e = s[f"error_{name}"].values
    x = e[np.isfinite(e)]
    return f"bias {x.mean():+.2f}, std {x.std(ddof=1):.2f} ({x.size} gates)"


def ray_end_phase(s: xr.Dataset, added: np.ndarray) -> tuple[float, float]:
    """Mean over the beams of Py-ART's Vulpiani phi_DP at each ray's last six gates with Z and
    phi_DP, as the Z-PHI block reconstructs it: the phase Z-PHI's total attenuation is
    alpha times."""
    os.environ.setdefault("PYART_QUIET", "1")
    from pasim_blocks.algorithms.sweep_radar import add_field, filled, make_radar, pyart

    ds = s.swap_dims({"azimuth": "beam"})
    radar = make_radar(ds, 5.6e9)
    add_field(radar, "psidp", ds["PHIDP"].values, "degrees")
    _, phidp = pyart().retrieve.kdp_vulpiani(
        radar, psidp_field="psidp", kdp_field="kdp", phidp_field="phidp", band="C"
    )
    phidp = filled(phidp)
    have = np.isfinite(ds["DBZH"].values) & np.isfinite(ds["PHIDP"].values)
    last = [np.flatnonzero(have[i])[-6:] for i in range(have.shape[0])]
    ends = [np.median(phidp[i, g]) for i, g in enumerate(last)]
    return float(np.mean(ends)), float(
        np.nanmean([np.nanmedian(added[i, g]) for i, g in enumerate(last)])
    )


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


def main() -> None:
    work = Path(sys.argv[1] if len(sys.argv) > 1 else "algorithms-cppar-runs")
    work.mkdir(exist_ok=True)
    s = {name: run(work, name) for name in RUNS}
    for name in (
        "propagation",
        "pyart",
        "no_gases",
        "expected_on",
        "expected_off",
        "rhohv08",
        "expected_on_rhohv08",
        "generic_propagation",
        "generic_rhohv08",
    ):
        print(f"{name}: DBZH {scored(s[name], 'DBZH')}; Z-PHI {scored(s[name], 'DBZH_ZPHI')}")
    print(f"propagation: KDP_VULPIANI {scored(s['propagation'], 'KDP_VULPIANI')}")
    for name in ("KDP_VULPIANI", "KDP_MAESAKA", "KDP_SCHNEEBELI"):
        if f"error_{name}" in s["schneebeli"]:
            print(f"297-303 deg: {name} {scored(s['schneebeli'], name)}")

    # Z-PHI's attenuation against the path's, gate by gate, without the estimator's noise.
    on, off = s["expected_on"], s["expected_off"]
    zon, zoff, zphi = on["DBZH"].values, off["DBZH"].values, on["DBZH_ZPHI"].values
    ok = on["scored"].values.astype(bool) & off["scored"].values.astype(bool)
    ok &= np.isfinite(zon) & np.isfinite(zoff) & np.isfinite(zphi)
    loss, pia = zoff - zon, zphi - zon
    extra = on["PHIDP"].values - off["PHIDP"].values  # the phase the path adds at C band
    print(
        f"expected level, {ok.sum()} gates: path loss {loss[ok].mean():.2f} dB, Z-PHI "
        f"{pia[ok].mean():.2f} dB, 2 x 0.07 x added phase {0.14 * np.nanmean(extra[ok]):.2f} dB"
    )
    edges = [-1.0, 0.5, 2, 4, 6, 8, 10, 15]
    mids, means = [], []
    for lo, hi in itertools.pairwise(edges):
        m = ok & (loss >= lo) & (loss < hi)
        print(
            f"  loss {lo:g}-{hi:g} dB: {m.sum()} gates, loss {loss[m].mean():.2f}, "
            f"Z-PHI {pia[m].mean():.2f}, over {(pia - loss)[m].mean():+.2f}"
        )
        mids.append(loss[m].mean())
        means.append(pia[m].mean())
    filtered = s["expected_on_rhohv08"]["DBZH_ZPHI"].values - zon
    kept = ok & np.isfinite(filtered)
    print(
        f"min_rhohv 0.8, expected level: {kept.sum()} gates, path loss "
        f"{loss[kept].mean():.2f} dB, Z-PHI {filtered[kept].mean():.2f} dB"
    )
    (end_on, added_on), (end_off, _) = ray_end_phase(on, extra), ray_end_phase(off, extra)
    print(
        f"ray ends: Vulpiani phase on {end_on:.1f} deg, off {end_off:.1f} deg; the phase the "
        f"path added there {added_on:.1f} deg (the C-band path phase is twice it)"
    )

    p = s["propagation"]
    truth = p["truth_DBZH"].values
    fig, axes = plt.subplots(1, 4, figsize=(19, 4.6))
    kw = {"cmap": "RdBu_r", "vmin": -10, "vmax": 10}
    ppi(axes[0], p, truth, "truth Z (dBZ)", cmap="viridis", vmin=0, vmax=65)
    ppi(axes[1], p, p["DBZH"].values - truth, "estimated Z - truth (attenuated, dB)", **kw)
    ppi(axes[2], p, p["DBZH_ZPHI"].values - truth, "Z-PHI (alpha 0.07) - truth (dB)", **kw)
    axes[0].set_ylabel("north (km)", fontsize=8)
    ax = axes[3]
    ax.hist2d(loss[ok], pia[ok], bins=60, range=[[-1, 14], [-1, 14]], cmap="Greys", norm=LogNorm())
    ax.plot(mids, means, "o-", color="C3", label="mean Z-PHI in bins of the loss")
    ax.plot([-1, 14], [-1, 14], color="C0", lw=0.8, label="Z-PHI = path loss")
    ax.set_xlabel("path loss of the beam (dB, expected level, gases off)", fontsize=8)
    ax.set_ylabel("Z-PHI's attenuation (dB)", fontsize=8)
    ax.set_title("Z-PHI against the path, gate by gate", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(
        "10 m CPPAR at 5.6 GHz through the KLBB squall line (graphs/zphi_cppar10_cband.yaml)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(DOCS / "algorithms_zphi_cppar.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
