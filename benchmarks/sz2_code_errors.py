"""SZ-2's recovery with the transmitter's phase-code errors (docs/doppler.md, the table and
docs/doppler_sz2_code_errors.png).

    python benchmarks/sz2_code_errors.py [--out docs] [--beams 100] [--gates 40]

Each case is ``beams`` beams of ``scan.ppi`` (SZ(8/64), 64 pulses, PRT 1 ms, 2.8 GHz) with
its ``phase_code_error_deg`` / ``phase_code_ripple_db``: the scan draws each beam's errors as
it does in a run, and every gate of the beam carries them. Per gate, two trips from the
spectral method of Zrnic (1975) (``tests.reference.spectral_series``): the strong trip
at SNR 100 dB, 5 m/s, width 2 m/s; the weak trip at 15 m/s, width 2 m/s, ``ratio`` dB
below it (so still 30 dB above the noise at 70 dB). Each echo carries the transmitted
phase and amplitude of the pulse that made it (trip 1 pulse m's, trip 2 pulse m - 1's, as
``channel.weather`` folds them); ``processor.sz2``'s :func:`separate_trips` decodes with the
ideal code, its ``code_leakage_db`` set to the theory's floor 10 log10(1 - exp(-(sigma^2 +
s^2))) (sigma the phase error in rad, s the ripple in nepers). Printed: the weak trip's
velocity error std over all gates (circular, on the +-26.8 m/s interval), the share the
default censoring removes and the std of those kept, and the ratio at which the std first
exceeds 2 m/s (linear interpolation in dB).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pasim_blocks.processing.sz2 import separate_trips, weak_censored  # noqa: E402
from pasim_blocks.receivers.phase_noise import (  # noqa: E402
    OVERSAMPLE,
    parse_profile,
    synthesise,
)
from pasim_blocks.scans.ppi import PPISector  # noqa: E402
from pasim_blocks.timing import code_errors, transmit_phase  # noqa: E402

from pasim_graph import Chunk  # noqa: E402
from tests.reference.phase_noise import flat_covariance, residual_fraction  # noqa: E402
from tests.reference.spectral_series import spectral_series  # noqa: E402

LAM = 299_792_458.0 / 2.8e9
T, M = 1e-3, 64
NY = LAM / (4 * T)
STRONG_SNR_DB = 100.0
LIMIT_MS = 2.0
#: receiver.phase_noise's default profile, cut at half the noise bandwidth of a 1.6 us
#: rectangular pulse's matched filter (625 kHz), the strong trip 1 at 100 km.
PHASE_NOISE = "1e3:-100, 1e7:-100"
PHASE_NOISE_CUT_HZ = 312.5e3
PHASE_NOISE_RANGE_M = 100e3
RATIOS = np.array(
    [0, 5, 10, 15, 20, 25, 30, 32.5, 35, 37.5, 40, 42.5, 45, 50, 55, 60, 62.5, 65, 67.5, 70]
)
CASES: dict[str, dict[str, Any]] = {
    "ideal code": {},
    "0.5 deg rms": {"phase_code_error_deg": 0.5},
    "0.2 deg rms": {"phase_code_error_deg": 0.2},
    "1 deg rms": {"phase_code_error_deg": 1.0},
    "0.1 dB ripple": {"phase_code_ripple_db": 0.1},
    "phase noise": {"phase_noise": PHASE_NOISE},
}


def oscillator(beams: int, seed: int, profile: str) -> tuple[np.ndarray, np.ndarray]:
    """exp(j D) of trip 1 and trip 2 (beam x pulse) at apparent range ``PHASE_NOISE_RANGE_M``
    through one oscillator with ``profile``, as receiver.phase_noise synthesises it (its
    ``synthesise``, cut at half the 1.6 us pulse's noise bandwidth): trip 1 at pulse m is
    phi(t_m) - phi(t_m + tau), trip 2 phi(t_(m-1)) - phi(t_m + tau) (sent one PRT earlier)."""
    offsets, levels = parse_profile(profile)
    keep = offsets < PHASE_NOISE_CUT_HZ
    level_cut = np.interp(np.log10(PHASE_NOISE_CUT_HZ), np.log10(offsets), levels)
    offsets = np.append(offsets[keep], PHASE_NOISE_CUT_HZ)
    levels = np.append(levels[keep], level_cut)
    rate = 2 * OVERSAMPLE * offsets[-1]
    tau = 2 * PHASE_NOISE_RANGE_M / 299_792_458.0
    n = 1 << int(np.ceil(np.log2((M + 1) * T * rate + tau * rate + 2)))
    grid = np.arange(n) / rate
    t = (np.arange(M) + 1) * T  # pulse m at t_m; pulse -1 at 0
    out1, out2 = [], []
    for b in range(beams):
        phi = synthesise(np.random.default_rng([seed, 7, b]), n, rate, offsets, levels)
        rx = np.interp(t + tau, grid, phi)
        out1.append(np.exp(1j * (np.interp(t, grid, phi) - rx)))
        out2.append(np.exp(1j * (np.interp(t - T, grid, phi) - rx)))
    return np.array(out1), np.array(out2)


def transmitted(params: dict, beams: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The ideal code (beam x pulse, rad) and the transmitted complex envelope (beam x pulse)
    of ``beams`` beams of scan.ppi with ``params``."""
    scan = PPISector(
        name="scan",
        prt_s=T,
        pulses=M,
        phase_code="sz8_64",
        azimuth_start_deg=0.0,
        azimuth_stop_deg=float(beams),
        **params,
    )
    scan.setup()
    ds = scan.process({}, Chunk(beams=np.arange(beams), seed=seed))["beams"]
    psi = transmit_phase(ds, M)
    errors = code_errors(ds, M)
    if errors is None:
        return psi, np.exp(1j * psi)
    return psi, errors[1] * np.exp(1j * (psi + errors[0]))


def weak_errors(params: dict, ratio_db: float, beams: int, gates: int, seed: int):
    """Weak-trip velocity errors (m/s) and censoring flags, beam x gate flattened."""
    scan_params = {k: v for k, v in params.items() if k != "phase_noise"}
    psi, tx = transmitted(scan_params, beams, seed)
    tx1, tx2 = tx, np.roll(tx, 1, axis=-1)  # trip 2 at pulse m: pulse m - 1's
    if "phase_noise" in params:
        d1, d2 = oscillator(beams, seed, params["phase_noise"])
        tx1, tx2 = tx1 * d1, tx2 * d2
    leakage = 10 ** (leak_floor_db(params) / 10)  # processor.sz2's code_leakage_db, as theory
    gen = np.random.default_rng([seed, int(ratio_db * 10)])
    p_s = 10 ** (STRONG_SNR_DB / 10)
    p_w = p_s / 10 ** (ratio_db / 10)
    errs, cens = [], []
    for b in range(beams):
        s1 = spectral_series(gen, gates, M, T, LAM, [(p_s, 5.0, 2.0)])
        s2 = spectral_series(gen, gates, M, T, LAM, [(p_w, 15.0, 2.0)])
        n = np.sqrt(0.5) * (gen.standard_normal((gates, M)) + 1j * gen.standard_normal((gates, M)))
        x = s1 * tx1[b] + s2 * tx2[b] + n
        est = separate_trips(x, psi[b], np.ones(gates), T, LAM, code_leakage=leakage)
        errs.append(np.mod(est["V2"] - 15.0 + NY, 2 * NY) - NY)
        cens.append(weak_censored(est, 60.0, 10.0))
    return np.concatenate(errs), np.concatenate(cens)


def crossing(ratios: np.ndarray, std: np.ndarray, limit: float = LIMIT_MS) -> float:
    """The ratio (dB) where ``std`` first exceeds ``limit`` (interpolated; NaN if never)."""
    above = np.flatnonzero(std > limit)
    if not above.size:
        return float("nan")
    i = above[0]
    if i == 0:
        return float(ratios[0])
    return float(np.interp(limit, std[i - 1 : i + 1], ratios[i - 1 : i + 1]))


def leak_floor_db(params: dict) -> float:
    """Theory: the incoherent fraction of a coded echo, 1 - exp(-(sigma^2 + s^2)), sigma the
    rms phase error (rad) and s the ripple's rms log-amplitude (nepers)."""
    sigma = np.deg2rad(params.get("phase_code_error_deg", 0.0))
    s = np.log(10) / 20 * params.get("phase_code_ripple_db", 0.0)
    frac = -np.expm1(-(sigma**2 + s**2))
    if "phase_noise" in params:
        # The flat profile's residual after the dwell's mean (tests/reference/phase_noise.py).
        _, levels = parse_profile(params["phase_noise"])
        tau = 2 * PHASE_NOISE_RANGE_M / 299_792_458.0
        cov = flat_covariance(float(levels[0]), PHASE_NOISE_CUT_HZ, tau, T, M)
        frac += residual_fraction(cov)
    return 10 * np.log10(frac) if frac > 0 else float("-inf")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--beams", type=int, default=100)
    ap.add_argument("--gates", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-figure", action="store_true")
    ap.add_argument("--only", default="", help="comma-separated case names")
    a = ap.parse_args()
    results = {}
    cases = {k: v for k, v in CASES.items() if not a.only or k in a.only.split(",")}
    for name, params in cases.items():
        rows = [weak_errors(params, r, a.beams, a.gates, a.seed) for r in RATIOS]
        std = np.array([e.std() for e, _ in rows])
        cens = np.array([c.mean() for _, c in rows])
        kept = np.array([e[~c].std() if (~c).sum() > 1 else np.nan for e, c in rows])
        results[name] = (std, cens, kept)
        print(
            f"{name}: floor {leak_floor_db(params):.1f} dB, std passes {LIMIT_MS} m/s at "
            f"{crossing(RATIOS, std):.1f} dB"
        )
    n = a.beams * a.gates
    print(f"\n{a.beams} beams x {a.gates} gates = {n} gates per point, seed {a.seed}\n")
    names = list(cases)
    print("| ratio (dB) | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")
    for i, r in enumerate(RATIOS):
        cells = [
            f"{results[k][0][i]:.2f} ({results[k][1][i]:.0%}, {results[k][2][i]:.2f})"
            for k in names
        ]
        print(f"| {r:g} | " + " | ".join(cells) + " |")
    print(
        "| crossing of 2 m/s (dB) | "
        + " | ".join(f"{crossing(RATIOS, results[k][0]):.1f}" for k in names)
        + " |"
    )
    if a.no_figure:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for i, k in enumerate(names):
        ax.semilogy(RATIOS, results[k][0], "o-", ms=3, color=f"C{i}", label=k)
    ax.axhline(LIMIT_MS, color="k", ls=":", lw=1)
    ax.text(1, LIMIT_MS * 1.08, f"{LIMIT_MS:g} m/s", fontsize=8)
    ax.set_xlabel("strong-to-weak power ratio (dB)")
    ax.set_ylabel("weak trip velocity error std (m/s)")
    ax.set_title(
        f"SZ-2, SZ(8/64), 64 pulses, strong trip 2 m/s wide, {n} gates per point", fontsize=9
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(a.out) / "doppler_sz2_code_errors.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
