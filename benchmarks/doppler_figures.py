"""Figures and tables of docs/doppler.md, from the blocks, the graphs and the test references.

    python benchmarks/doppler_figures.py [--out docs]

Prints the GMAP table, the staggered-PRT and clutter-width numbers, and writes
doppler_gmap_spectra.png, doppler_staggered.png and doppler_folding.png.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"
sys.path.insert(0, str(ROOT))

from pasim_blocks.processing.gmap import clutter_shape, gmap  # noqa: E402
from pasim_blocks.processing.spectral import (  # noqa: E402
    bin_velocities,
    moments_from_spectrum,
    periodogram,
    window,
)

from pasim_graph.executor import LocalExecutor, RunOptions  # noqa: E402
from pasim_graph.graph import load  # noqa: E402
from tests.reference.spectral_series import spectral_series  # noqa: E402

LAM = 299_792_458.0 / 2.8e9
T, M, G = 1e-3, 64, 2000
NY = LAM / (4 * T)


def gmap_case(v0, csr_db, name, seed):
    comps = [(1000.0, v0, 2.0)] + ([(1000.0 * 10 ** (csr_db / 10), 0.0, 0.25)] if csr_db else [])
    x = spectral_series(np.random.default_rng(seed), G, M, T, LAM, comps, 1.0)
    w = window(name, M)
    s = periodogram(x, w)
    raw = moments_from_spectrum(s, w, 1.0, T, LAM)
    res = gmap(s, np.ones(G), clutter_shape(w, 0.25, T, LAM), bin_velocities(M, T, LAM), NY)
    filt = moments_from_spectrum(res.spectrum, w, 1.0, T, LAM)
    return s, res, raw, filt


def stats(est, v0):
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.nanmean(10 * np.log10(est["S_H"] / 1000.0))
    e = np.mod(est["VRADH"] - v0 + NY, 2 * NY) - NY
    return z, np.nanmean(e), np.nanstd(e), np.nanmean(est["WRADH"])


def gmap_table():
    print(
        "| window | v (m/s) | clutter | filter | DBZH bias (dB) | VRADH bias | VRADH std |"
        " WRADH mean | removed (dB) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name in ("hann", "blackman", "blackman_harris"):
        for v0 in (5.0, 0.0):
            for csr in (None, 40.0):
                _, res, raw, filt = gmap_case(v0, csr, name, 11)
                for label, est in (("none", raw), ("GMAP", filt)):
                    z, b, s, w = stats(est, v0)
                    rem = np.median(res.correction_db) if label == "GMAP" else 0.0
                    print(
                        f"| {name} | {v0:g} | {'40 dB' if csr else 'none'} | {label} | "
                        f"{z:+.2f} | {b:+.2f} | {s:.2f} | {w:.2f} | {rem:.1f} |"
                    )


def spectra_figure(out):
    import matplotlib.pyplot as plt

    v = np.fft.fftshift(bin_velocities(M, T, LAM))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, v0 in zip(axes, (5.0, 0.0), strict=True):
        s, res, _, _ = gmap_case(v0, 40.0, "blackman_harris", 12)
        clean, _, _, _ = gmap_case(v0, None, "blackman_harris", 12)
        for spec, label, style in (
            (s, "weather + clutter (40 dB)", "-"),
            (res.spectrum, "after GMAP", "-"),
            (clean, "weather alone", "--"),
        ):
            ax.plot(v, 10 * np.log10(np.fft.fftshift(spec.mean(axis=0))), style, label=label)
        ax.axhline(10 * np.log10(1 / M), color="grey", lw=0.8, ls=":", label="noise per bin")
        ax.set_title(f"weather at {v0:g} m/s, w 2 m/s, SNR 30 dB")
        ax.set_xlabel("velocity (m/s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mean power per bin (dB, noise = 0 dB total)")
    axes[0].legend(fontsize=8)
    fig.suptitle("GMAP on 2,000 gates (64 pulses, PRT 1 ms, Blackman-Harris window)")
    fig.tight_layout()
    fig.savefig(out / "doppler_gmap_spectra.png", dpi=110)


def staggered_figure(out):
    import matplotlib.pyplot as plt

    truths = np.linspace(-60, 60, 25)
    rows = []
    for v in truths:
        base = {"scene.velocity_ms": float(v), "scan.azimuth_stop_deg": 3.0, "scene.gates": 100}
        stag = LocalExecutor(load(GRAPHS / "uniform_staggered.yaml", base), RunOptions()).run()
        unif = LocalExecutor(load(GRAPHS / "uniform_ideal.yaml", base), RunOptions()).run()
        rows.append(
            (
                np.nanmedian(stag["VRADH"].values),
                np.nanmedian(unif["VRADH"].values),
                np.nanstd(stag["error_VRADH"].values),
            )
        )
    rows = np.array(rows)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(truths, truths, color="grey", lw=0.8, label="truth")
    ax.plot(truths, rows[:, 1], "o", label="uniform PRT 1 ms (v_a 26.8 m/s)")
    ax.plot(truths, rows[:, 0], "s", mfc="none", label="staggered 2/3, 1 / 1.5 ms (v_e 53.5 m/s)")
    for ve in (26.77, 53.53):
        ax.axvspan(-ve, ve, alpha=0.06)
    ax.set_xlabel("true velocity (m/s)")
    ax.set_ylabel("estimated velocity, median over 300 gates (m/s)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title("Staggered PRT through the chain (w 2 m/s, SNR 20 dB, 64 pulses)")
    fig.tight_layout()
    fig.savefig(out / "doppler_staggered.png", dpi=110)
    inside = np.abs(truths) < 53.5
    print("staggered: std of the scored error inside +-v_e:", np.round(rows[inside, 2], 2))


def folding_figure(out):
    import matplotlib.pyplot as plt

    pp = LocalExecutor(
        load(GRAPHS / "range_folding.yaml", {"scene.reflectivity_dbz": 20.0}), RunOptions()
    ).run()
    sz = LocalExecutor(load(GRAPHS / "sz2_folding.yaml"), RunOptions()).run()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    r = pp["range"].values / 1e3
    for ax, sweep, title in ((axes[0], pp, "pulse pair, no code"), (axes[1], sz, "SZ(8/64), SZ-2")):
        ax.plot(
            r,
            10 * np.log10(np.nanmean(10 ** (sweep["DBZH"].values / 10), axis=0)),
            label="estimate (mean of 20 beams)",
        )
        truth = np.nanmean(sweep["truth_DBZH"].values, axis=0)
        ax.plot(r, truth, color="k", lw=0.8, ls="--", label="truth")
        ax.axvline(149.9, color="k", lw=0.8, ls=":")
        ax.set_title(f"PRT 1 ms (r_a 149.9 km): {title}")
        ax.set_xlabel("range (km)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("DBZH (dBZ)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "doppler_folding.png", dpi=110)


def clutter_widths():
    base = (GRAPHS / "generic_radar_clutter.yaml").read_text()
    planar = (GRAPHS / "planar_patch_radar.yaml").read_text()
    antenna = next(line for line in planar.splitlines() if line.startswith("  antenna:"))
    array = (
        "\n".join(antenna if line.startswith("  antenna:") else line for line in base.splitlines())
        + "\n"
    )
    array = array.replace("peak_power_w: 700000.0", "peak_power_w: 76800.0")
    tmp = Path("/tmp/pasim_doppler_planar_clutter.yaml")
    tmp.write_text(array)
    over = {
        "clutter.source": "uniform",
        "clutter.clutter_dbz": 90.0,
        "clutter.extent_m": 20000.0,
        "scan.azimuth_start_deg": 280.0,
        "scan.azimuth_stop_deg": 284.0,
    }
    for label, path in (
        ("dish (antenna.pencil)", GRAPHS / "generic_radar_clutter.yaml"),
        ("planar array", tmp),
    ):
        sweep = LocalExecutor(load(path, over), RunOptions(save_iq=True)).run()
        iq = sweep["IQ_H"].values[:, (sweep["range"].values > 2e3) & (sweep["range"].values < 19e3)]
        for lag in (8, 16):
            r = np.mean(np.conj(iq[..., :-lag]) * iq[..., lag:])
            r0 = np.mean(np.abs(iq) ** 2)
            prt = 1 / 300
            w = LAM / (np.pi * lag * prt) * np.sqrt(-np.log(abs(r) / r0) / 8)
            print(f"clutter width, {label}, lag {lag}: {w:.3f} m/s")


def sz2_table():
    from pasim_blocks.processing.sz2 import separate_trips, weak_censored
    from pasim_blocks.timing import sz_code

    psi = sz_code(8, 64)
    print("| strong width (m/s) | ratio (dB) | weak VRADH std, all (m/s) | censored | std kept |")
    print("|---|---|---|---|---|")
    for ws in (2.0, 4.0, 6.0):
        for ratio in (20, 30, 40, 50, 60):
            gen = np.random.default_rng(ratio)
            p_s = 1e8
            s1 = spectral_series(gen, G, M, T, LAM, [(p_s, 5.0, ws)])
            s2 = spectral_series(gen, G, M, T, LAM, [(p_s / 10 ** (ratio / 10), 15.0, 2.0)])
            n = np.sqrt(0.5) * (gen.standard_normal((G, M)) + 1j * gen.standard_normal((G, M)))
            x = s1 * np.exp(1j * psi) + s2 * np.exp(1j * np.roll(psi, 1)) + n
            est = separate_trips(x, psi, np.ones(G), T, LAM)
            e = np.mod(est["V2"] - 15.0 + NY, 2 * NY) - NY
            cens = weak_censored(est, 60.0, 10.0)
            kept = f"{e[~cens].std():.2f}" if (~cens).sum() > 1 else "-"
            print(f"| {ws:g} | {ratio} | {e.std():.2f} | {cens.mean():.0%} | {kept} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    out = Path(a.out)
    steps = {
        "table": gmap_table,
        "spectra": lambda: spectra_figure(out),
        "staggered": lambda: staggered_figure(out),
        "folding": lambda: folding_figure(out),
        "clutter": clutter_widths,
        "sz2": sz2_table,
    }
    for name, step in steps.items():
        if not a.only or name in a.only.split(","):
            step()


if __name__ == "__main__":
    main()
