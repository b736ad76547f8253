"""Figures and tables of docs/arrays.md, from the blocks and the graphs (reproducible).

    python benchmarks/arrays_figures.py [--out docs] [--runs DIR]

``--runs DIR`` also plots the per-azimuth biases of the planar radar's runs stored there
(``planar_{per_beam,boresight}_{covariance,expected}.zarr`` and
``pencil_{1.0,1.64,2.32}_expected.zarr``, made with the commands in docs/arrays.md).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"
SYSTEMS = [
    ("generic_radar", "generic (Table 4)"),
    ("atd_radar", "ATD (Table 5)"),
    ("cppar2_radar", "CPPAR 2 m (Table 6)"),
    ("cppar10_radar", "CPPAR 10 m (Table 6)"),
    ("cppar10_impaired", "CPPAR 10 m, impaired (seed 0)"),
]


def db(x):
    with np.errstate(divide="ignore"):
        return 10 * np.log10(x)


def system_table(out: Path) -> list[dict]:
    from pasim_blocks.antennas.beam_figures import build, measure

    from pasim_graph import load

    rows = []
    for name, label in SYSTEMS:
        block = build(load(GRAPHS / f"{name}.yaml"), "antenna")
        m = measure(block, 0.0, 0.0, span_deg=90.0)
        rows.append({"graph": name, "label": label, **{k: v for k, v in m.items() if k != "cuts"}})
        rows[-1]["cuts"] = m["cuts"]

    def finite(v):
        return None if isinstance(v, float) and not np.isfinite(v) else v

    (ROOT / "benchmarks" / "results" / "arrays_systems.json").write_text(
        json.dumps([{k: finite(v) for k, v in r.items() if k != "cuts"} for r in rows], indent=1)
    )
    return rows


def plot_systems(rows: list[dict], out: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows) - 1, 2, figsize=(11, 10), sharey=True)
    for row, (ax_az, ax_el) in zip(rows[:-1], axes, strict=True):
        for ax, key in ((ax_az, "azimuth"), (ax_el, "elevation")):
            d, c = row["cuts"][key]
            peak = c["h_co"].max()
            ax.plot(d, db(c["h_co"] / peak), lw=0.7, label="H")
            ax.plot(d, db(c["v_co"] / peak), lw=0.7, alpha=0.8, label="V")
            if np.any(c["v_cross"] > 0):
                ax.plot(d, db(c["v_cross"] / peak), lw=0.6, ls=":", label="V cross")
            ax.set_ylim(-70, 3)
            ax.grid(alpha=0.3)
        ax_az.set_ylabel(row["label"], fontsize=8)
    axes[-1][0].set_xlabel("azimuth from the beam (deg)")
    axes[-1][1].set_xlabel("elevation from the beam (deg)")
    axes[0][1].legend(fontsize=7, loc="upper right")
    fig.suptitle("one-way patterns at broadside (dB, H peak = 0), `pasim pattern` cuts", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "arrays_patterns.png", dpi=110)
    plt.close(fig)


def plot_impaired(out: Path) -> dict:
    """Paper figure 5: the 10 m CPPAR with C2C errors and failures, and with 5-bit phase
    shifters, against the ideal array; the 20-seed mean sidelobe level against Mailloux."""
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.cylindrical import CylindricalArray
    from pasim_blocks.antennas.tapers import taper_efficiency

    d = np.arange(-90.0, 90.0001, 0.02)
    variants = {
        "ideal": {},
        "errors": {"amplitude_error_db": 0.5, "phase_error_deg": 6.0, "failure_probability": 0.05},
        "5-bit": {"phase_bits": 5},
        "all": {
            "amplitude_error_db": 0.5,
            "phase_error_deg": 6.0,
            "failure_probability": 0.05,
            "phase_bits": 5,
        },
    }
    cuts = {}
    base = CylindricalArray(name="antenna", elements_per_column=8)
    az0, _ = base.broadside()
    matrix = base.column_matrix(az0, 0.0, az0 + d, np.zeros_like(d))[0]
    for key, params in variants.items():
        block = CylindricalArray(name="antenna", elements_per_column=8, **params)
        first, offset = block.sector(az0)
        seeds = range(20) if key == "all" else [0]
        cuts[key] = np.array(
            [
                np.abs(
                    matrix @ block.column_weights(first, offset * block.column_step_deg, 0, s)[0]
                )
                ** 2
                for s in seeds
            ]
        )
    peak = cuts["ideal"].max()
    sigma2 = (np.log(10) / 20 * 0.5) ** 2 + np.deg2rad(6) ** 2 + 0.05 + (2 * np.pi / 32) ** 2 / 12
    floor = sigma2 / (156 * taper_efficiency(base.amplitude))
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8), sharey=True)
    axes[0].plot(d, db(cuts["ideal"][0] / peak), color="0.6", lw=0.8, label="ideal")
    axes[0].plot(d, db(cuts["errors"][0] / peak), lw=0.7, label="0.5 dB / 6 deg, 5 % failed")
    axes[1].plot(d, db(cuts["ideal"][0] / peak), color="0.6", lw=0.8, label="ideal")
    axes[1].plot(d, db(cuts["5-bit"][0] / peak), lw=0.7, label="5-bit phase shifters")
    mean = cuts["all"].mean(axis=0)
    axes[2].plot(d, db(mean / peak), lw=0.8, label="all impairments, mean of 20 seeds")
    axes[2].axhline(db(floor), color="k", ls="--", lw=0.8, label="Mailloux level")
    axes[2].plot(d, db(cuts["ideal"][0] / peak), color="0.6", lw=0.6, label="ideal")
    for ax in axes:
        ax.set_ylim(-70, 3)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
        ax.set_xlabel("azimuth from the beam (deg)")
    axes[0].set_ylabel("one-way H power (dB, ideal peak = 0)")
    fig.suptitle("10 m CPPAR (paper figure 5): channel errors, quantisation, average", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "arrays_impaired.png", dpi=110)
    plt.close(fig)
    region = (np.abs(d) >= 5) & (np.abs(d) <= 20)
    return {"mailloux_db": float(db(floor)), "mean_5_20_db": float(db(mean[region].mean() / peak))}


def plot_quantisation_lobes(out: Path) -> None:
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.planar import PlanarPatchArray

    d = np.arange(-85.0, 85.0, 0.02)
    keep = np.abs(20 + d) < 89
    fig, ax = plt.subplots(figsize=(8, 3.5))
    peak = None
    for label, params in (
        ("ideal", {}),
        ("5-bit", {"phase_bits": 5}),
        ("5-bit, randomised", {"phase_bits": 5, "randomize_quantization": True}),
        ("subarray steering (8 x 8)", {"subarray_x": 8, "subarray_y": 8, "steering": "subarray"}),
    ):
        block = PlanarPatchArray(name="antenna", face_azimuth_deg=0.0, **params)
        p = np.abs(block.fields_at(20.0, 0.0, 20 + d[keep], np.zeros(keep.sum())).h_co) ** 2
        peak = p.max() if peak is None else peak
        ax.plot(d[keep], db(p / peak), lw=0.7, label=label)
    ax.set_ylim(-70, 3)
    ax.set_xlabel("azimuth from the beam (deg)")
    ax.set_ylabel("one-way H (dB)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("80 x 80 planar array steered 20 deg: quantisation and grating lobes", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "arrays_quantisation.png", dpi=110)
    plt.close(fig)


def plot_zdr_bias(out: Path) -> dict:
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.beam_figures import measure
    from pasim_blocks.antennas.cylindrical import CylindricalArray
    from pasim_blocks.antennas.planar import PlanarPatchArray

    steers = np.arange(0.0, 46.0, 5.0)
    curves = {}
    for label, params in (
        ("planar, patch 5.24 cm (paper)", {}),
        ("planar, patch 3.5 cm", {"patch_m": 0.035}),
        ("planar, crossed dipoles", {"element": "crossed_dipole"}),
        ("planar, isotropic", {"element": "isotropic"}),
    ):
        block = PlanarPatchArray(name="antenna", **params)
        curves[label] = [
            measure(block, s, 0.0, span_deg=6.0, step_deg=0.01)["zdr_bias_db"] for s in steers
        ]
    cyl = CylindricalArray(name="antenna", elements_per_column=32)
    curves["cylinder 10 m, patch (commutated)"] = [
        measure(cyl, s, 0.0, span_deg=3.0, step_deg=0.01)["zdr_bias_db"] for s in steers
    ]
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for label, values in curves.items():
        ax.plot(steers, values, marker="o", ms=3, label=label)
    ax.set_xlabel("beam azimuth from broadside (deg)")
    ax.set_ylabel("ZDR bias: two-way H/V at the peak (dB)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "arrays_zdr_bias.png", dpi=110)
    plt.close(fig)
    return {k: [round(v, 3) for v in vals] for k, vals in curves.items()}


def plot_zdr_coupling(out: Path) -> dict:
    """ATD's ZDR bias and scan loss with steering: isolated patch against embedded elements."""
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.beam_figures import build, measure

    from pasim_graph.graph import load

    graph = load(GRAPHS / "atd_radar.yaml")
    steers = np.arange(0.0, 46.0, 5.0)
    cases = (
        ("isolated patch (paper, fig. 9e)", {}),
        ("isolated patch x Wheeler mismatch", {"coupling": "model"}),
        ("embedded cell cos(theta), matched", {"embedded_pattern": "cell"}),
        ("embedded cell x Wheeler mismatch", {"embedded_pattern": "cell", "coupling": "model"}),
    )
    results: dict = {}
    for label, params in cases:
        block = build(graph, "antenna", **params)
        rows = [measure(block, s, 0.0, span_deg=6.0, step_deg=0.01) for s in steers]
        el10 = [measure(block, s, 10.0, span_deg=6.0, step_deg=0.01) for s in (0.0, 45.0)]
        gain = np.array([r["peak_gain_dbi"] for r in rows])
        v_peak = np.array([r["peak_gain_dbi"] - r["zdr_bias_db"] / 2 for r in rows])
        results[label] = {
            "zdr_bias_db": [round(r["zdr_bias_db"], 3) for r in rows],
            "scan_loss_h_db": [round(float(g), 3) for g in gain - gain[0]],
            "scan_loss_v_db": [round(float(g), 3) for g in v_peak - v_peak[0]],
            "zdr_bias_el10_db": [round(r["zdr_bias_db"], 3) for r in el10],
        }
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for i, (label, r) in enumerate(results.items()):
        axes[0].plot(steers, r["zdr_bias_db"], marker="o", ms=3, color=f"C{i}", label=label)
        axes[1].plot(steers, r["scan_loss_h_db"], marker="o", ms=3, color=f"C{i}", label="H")
        axes[1].plot(steers, r["scan_loss_v_db"], ls="--", color=f"C{i}", label="V")
    axes[0].set_ylabel("ZDR bias: two-way H/V at the peak (dB)")
    axes[1].set_ylabel("one-way peak gain over broadside (dB)")
    for ax in axes:
        ax.set_xlabel("beam azimuth from broadside (deg)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[1].legend(["H (solid)", "V (dashed)"], fontsize=7, loc="lower left")
    fig.suptitle("ATD, 80 x 80 patches: isolated against embedded elements", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "arrays_zdr_coupling.png", dpi=110)
    plt.close(fig)
    return results


def plot_calibration(runs: Path, out: Path) -> dict:
    import matplotlib.pyplot as plt
    import xarray as xr

    names = [
        "planar_boresight_covariance.zarr",
        "planar_boresight_expected.zarr",
        "planar_per_beam_covariance.zarr",
        "planar_per_beam_expected.zarr",
        "pencil_1.64_expected.zarr",
        "pencil_2.32_expected.zarr",
    ]
    sweeps = {
        n: xr.open_datatree(runs / n, engine="zarr")["sweep_0"].to_dataset()
        for n in names
        if (runs / n).exists()
    }
    # The same gates for every run: scored in all of them.
    common = np.logical_and.reduce([np.isfinite(s["error_DBZH"].values) for s in sweeps.values()])

    def profile(name: str, field: str, width: float = 5.0):
        s = sweeps[name]
        e, az = np.where(common, s[f"error_{field}"].values, np.nan), s["azimuth"].values
        centres = np.arange(240, 330, width) + width / 2
        values = [np.nanmean(e[np.abs(az - c) < width / 2]) for c in centres]
        return centres, np.array(values)

    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    table = {}
    for name, style in (
        ("planar_boresight_covariance.zarr", dict(color="C3", label="boresight, covariance")),
        ("planar_boresight_expected.zarr", dict(color="C3", ls="--", label="boresight, expected")),
        ("planar_per_beam_covariance.zarr", dict(color="C0", label="per beam, covariance")),
        ("planar_per_beam_expected.zarr", dict(color="C0", ls="--", label="per beam, expected")),
        ("pencil_1.64_expected.zarr", dict(color="0.5", ls=":", label="1.64 deg pencil, expected")),
        ("pencil_2.32_expected.zarr", dict(color="0.2", ls=":", label="2.32 deg pencil, expected")),
    ):
        if name not in sweeps:
            continue
        for ax, field in zip(axes, ("DBZH", "ZDR"), strict=True):
            x, y = profile(name, field)
            ax.plot(x, y, marker="o", ms=2.5, lw=0.9, **style)
            table[f"{name}:{field}"] = [round(float(v), 2) for v in y]
            table[f"{name}:{field}:10deg"] = [
                round(float(v), 2) for v in profile(name, field, 10.0)[1]
            ]
    table["common_gates"] = int(common.sum())
    for ax, field in zip(axes, ("DBZH", "ZDR"), strict=True):
        ax.axvline(285, color="k", lw=0.5)
        ax.set_xlabel("azimuth (deg; the face points at 285)")
        ax.set_ylabel(f"mean {field} error per 5 deg (dB)")
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-15, 3)
    axes[1].set_ylim(-4.5, 0.8)
    axes[1].legend(fontsize=7, loc="lower center")
    fig.suptitle(
        "planar patch radar, KLBB 240-330 deg: boresight vs per-beam calibration", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(out / "arrays_calibration.png", dpi=110)
    plt.close(fig)
    return table


def plot_crosspol(out: Path) -> dict:
    """ZDR bias against the element leakage through the weather channel and the processor
    (the uniform medium of tests/weather/test_crosspol.py), SHV at its worst transmit phase and AHV,
    with the exact bias of the coincident-pattern model and Zrnic et al.'s first order."""
    import sys

    import matplotlib.pyplot as plt

    sys.path.insert(0, str(ROOT))
    from tests.weather.test_crosspol import (
        PHIDP_DEG,
        RHO,
        ZDR_DB,
        ahv_bias_db,
        leaky_array,
        moments,
        scene,
        with_antenna,
        worst_beta,
    )
    from tests.weather.test_polarimetry import closed_form_bias_db, first_order_bias_db

    levels = np.arange(-45.0, -19.0, 2.5)  # the first-order formula fails beyond -20 dB
    inputs = scene()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    results = {}
    for ax, phase in zip(axes, (0.0, 90.0), strict=True):
        rows = []
        for level in levels:
            x = 10 ** (level / 20) * np.exp(1j * np.deg2rad(phase))
            beta = worst_beta(x)
            leaky = with_antenna(inputs, leaky_array(level, phase))
            shv = float(moments(leaky, transmit_differential_phase_deg=beta)["ZDR"].mean())
            ahv = float(moments(leaky, transmission="ahv")["ZDR"].mean())
            args = (x, beta, ZDR_DB, RHO, PHIDP_DEG)
            rows.append(
                {
                    "level_db": float(level),
                    "beta_deg": beta,
                    "shv": shv - ZDR_DB,
                    "shv_exact": closed_form_bias_db(*args),
                    "shv_first_order": first_order_bias_db(*args),
                    "ahv": ahv - ZDR_DB,
                    "ahv_second_order": ahv_bias_db(x, order=2),
                }
            )
        col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        ax.semilogy(levels, abs(col["shv_exact"]), "C0-", label="SHV, exact (model)")
        ax.semilogy(
            levels, abs(col["shv_first_order"]), "C0--", label="SHV, first order (Zrnic 2010)"
        )
        ax.semilogy(levels, abs(col["shv"]), "C0o", ms=4, label="SHV, weather channel")
        ax.semilogy(levels, abs(col["ahv_second_order"]), "C1-", label="AHV, second order")
        ax.semilogy(levels, abs(col["ahv"]), "C1s", ms=4, label="AHV, weather channel")
        ax.set_title(f"leakage phase {phase:.0f} deg (SHV at its worst transmit phase)", fontsize=9)
        ax.set_xlabel("element cross-polar level (dB)")
        ax.grid(alpha=0.3, which="both")
        results[f"phase_{phase:.0f}"] = rows
    axes[0].set_ylabel(f"|ZDR bias| (dB), Zdr {ZDR_DB:g} dB, rho {RHO:g}, phi_DP {PHIDP_DEG:g}")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "arrays_crosspol.png", dpi=110)
    plt.close(fig)
    return results


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--runs", default=None)
    ap.add_argument("--only", nargs="*", default=None)
    args = ap.parse_args()
    out = Path(args.out)
    results: dict = {}
    todo = args.only or [
        *("systems", "impaired", "quantisation", "zdr", "coupling", "crosspol", "calibration")
    ]
    if "systems" in todo:
        rows = system_table(out)
        plot_systems(rows, out)
        results["systems"] = [{k: v for k, v in r.items() if k != "cuts"} for r in rows]
    if "impaired" in todo:
        results["impaired"] = plot_impaired(out)
    if "quantisation" in todo:
        plot_quantisation_lobes(out)
    if "zdr" in todo:
        results["zdr"] = plot_zdr_bias(out)
    if "coupling" in todo:
        results["coupling"] = plot_zdr_coupling(out)
    if "crosspol" in todo:
        results["crosspol"] = plot_crosspol(out)
    if "calibration" in todo and args.runs:
        results["calibration"] = plot_calibration(Path(args.runs), out)
    print(json.dumps(results, indent=1, default=float))


if __name__ == "__main__":
    main()
