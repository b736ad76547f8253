"""SZ-2 phase-coded processing: two overlaid trips separated (Sachidananda and Zrnic 1999).

Sachidananda, M. and D. S. Zrnic (1999), *Systematic phase codes for resolving range
overlaid signals in a Doppler weather radar*, J. Atmos. Oceanic Technol. 16, 1351-1363; the
WSR-88D implementation: Frush et al. (2002) and Torres and Zrnic (2006, NSSL report
"Evolution of the SZ-2 algorithm"). The transmitter's phases psi_m follow the SZ(8/64)
code (scan.ppi ``phase_code``; :func:`pasim_blocks.timing.sz_code`). Per gate of the first
trip's range (r < c T / 2), with x the received series:

1. Cohere to trip 1 (x e^(-j psi_m)) and to trip 2 (x e^(-j psi_(m-1))): the cohered trip is
   a Gaussian echo, the other is modulated by the switching code and spread into 8 equal
   spectral replicas (white to the lag-1 and lag-2 autocorrelations). The strong trip is
   the one whose cohered series has the larger |R(1)|.
2. Strong trip: velocity from the phase of R(1) of its cohered series; width from the
   lag-1 to lag-2 ratio, sigma = lambda / (2 sqrt(6) pi T) sqrt(ln(|R(1)| / |R(2)|)) (the
   other trip and the noise do not bias either lag).
3. Weak trip: the strong-cohered series is windowed (von Hann), transformed, and a notch
   removes the 3/4 of the spectrum centred on the strong trip's velocity; what is left holds
   2 of the weak trip's 8 replicas. Re-cohered to the weak trip, its lag-1 phase gives the
   weak trip's velocity (the replicas left are symmetric about it). Its power is four times
   the power left (the notch keeps 1/4 of the weak trip's and of the noise's), corrected
   for the window; the strong trip's is the total less the weak's.
4. Censoring: the weak trip is censored where the strong-to-weak power ratio exceeds
   ``max_power_ratio_db`` (beyond it the strong trip's leakage through the notch, set by its
   width and the window's sidelobes, swamps the weak trip) or its SNR is below the Doppler
   threshold. Each trip's moments go to its own range: trip 2's at r + c T / 2.

Reflectivity, velocity and width are estimated (H channel); the polarimetric moments are
not (the SZ-2 of the WSR-88D estimates them on the long-PRT surveillance scan).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import scipy.signal

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import BEAMS, CALIBRATION, IQ, MOMENTS, NOISE_POWER, SPEED_OF_LIGHT
from ..timing import transmit_phase
from .gmap import clutter_shape
from .output import Censoring, moments_dataset, thresholds

#: Fraction of the spectrum the notch removes around the strong trip (SZ(8/64): 3/4).
NOTCH_FRACTION = 0.75
#: The strong trip's leakage is taken at its estimated width times this: the Gaussian tail
#: through the notch grows by orders of magnitude with the width, which a dwell estimates
#: to 10-20 %.
WIDTH_MARGIN = 1.25


def lag(x: np.ndarray, k: int) -> np.ndarray:
    """Sample autocorrelation at lag k along the last axis."""
    return np.mean(np.conj(x[..., :-k]) * x[..., k:], axis=-1)


def leakage_table(
    win: np.ndarray, prt_s: float, wavelength_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Fraction of a Gaussian echo's windowed power the notch passes, against its width
    (m/s): the expected periodogram (window leakage included) summed beyond the notch."""
    return _leakage_table(tuple(win), prt_s, wavelength_m)


@functools.lru_cache(maxsize=8)
def _leakage_table(
    window: tuple[float, ...], prt_s: float, wavelength_m: float
) -> tuple[np.ndarray, np.ndarray]:
    win = np.asarray(window)
    m = win.size
    widths = np.linspace(0.0, wavelength_m / (4 * prt_s), 200)
    freq_bin = np.abs(np.fft.fftfreq(m) * m)
    passed = freq_bin > NOTCH_FRACTION * m / 2
    frac = np.empty(widths.size)
    for i, w in enumerate(widths):
        shape = clutter_shape(win, max(w, 1e-3), prt_s, wavelength_m)
        frac[i] = shape[passed].sum() / shape.sum()
    return widths, frac


def separate_trips(
    x: np.ndarray, psi: np.ndarray, noise_w: np.ndarray, prt_s: float, wavelength_m: float
) -> dict[str, np.ndarray]:
    """SZ-2 estimates of two overlaid trips from series ``x`` (gate x pulse) transmitted with
    phases ``psi`` (pulse, rad); ``noise_w`` per gate.

    Returns per gate: ``strong`` (1 or 2), and for ``1`` and ``2`` the power (W), velocity
    and width (m/s) of that trip (``P1``, ``V1``, ``W1``, ``P2``, ...), the weak trip's width
    NaN where not estimated.
    """
    m = x.shape[-1]
    c = [np.exp(-1j * psi), np.exp(-1j * np.roll(psi, 1))]  # cohere to trip 1, trip 2
    cohered = [x * ci for ci in c]
    r1 = [lag(ci, 1) for ci in cohered]
    strong = np.where(np.abs(r1[0]) >= np.abs(r1[1]), 0, 1)  # index of the strong trip
    pick = strong[:, None] == 0
    xs = np.where(pick, cohered[0], cohered[1])
    r1_s = np.where(strong == 0, r1[0], r1[1])
    r2_s = lag(xs, 2)
    k_vel = -wavelength_m / (4 * np.pi * prt_s)
    v_s = k_vel * np.angle(r1_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        ln = np.log(np.abs(r1_s) / np.abs(r2_s))
    w_s = wavelength_m / (2 * np.sqrt(6) * np.pi * prt_s) * np.sqrt(np.maximum(ln, 0))
    # Weak trip: window, notch 3/4 around the strong trip's velocity, re-cohere.
    win = np.asarray(scipy.signal.get_window("hann", m, fftbins=False), np.float64)
    spec = np.fft.fft(xs * win, axis=-1)
    freq_bin = np.fft.fftfreq(m) * m  # signed bin index
    centre = np.angle(r1_s) / (2 * np.pi) * m  # strong trip's bin (lag-1 phase)
    dist = np.abs(np.mod(freq_bin[None, :] - centre[:, None] + m / 2, m) - m / 2)
    keep = dist > NOTCH_FRACTION * m / 2
    y = np.fft.ifft(np.where(keep, spec, 0), axis=-1)
    # From strong-cohered to weak-cohered: times e^(-j psi_weak) / e^(-j psi_strong).
    switch = np.where(pick, c[1] / c[0], c[0] / c[1])
    yw = y * switch
    mean_w2 = float(np.mean(win**2))
    kept = np.mean(np.abs(yw) ** 2, axis=-1) / mean_w2
    total = np.mean(np.abs(x) ** 2, axis=-1) - noise_w
    # What of the strong trip the notch lets through (its Gaussian spectrum seen through
    # the window), in units of the weak trip's power estimate.
    leak = np.interp(WIDTH_MARGIN * w_s, *leakage_table(win, prt_s, wavelength_m))
    leak /= 1 - NOTCH_FRACTION
    leak_w = leak * np.maximum(total, 0) / (1 + leak)
    p_w = kept / (1 - NOTCH_FRACTION) - noise_w - leak_w
    p_s = total - np.maximum(p_w, 0)
    r1_w = lag(yw, 1)
    v_w = k_vel * np.angle(r1_w)
    first = strong == 0
    return {
        "strong": strong + 1,
        "leak": leak_w,
        "P1": np.where(first, p_s, p_w),
        "P2": np.where(first, p_w, p_s),
        "V1": np.where(first, v_s, v_w),
        "V2": np.where(first, v_w, v_s),
        "W1": np.where(first, w_s, np.nan),
        "W2": np.where(first, np.nan, w_s),
    }


def weak_censored(est: dict[str, np.ndarray], max_ratio_db: float, margin_db: float) -> np.ndarray:
    """Gates whose weak trip cannot be recovered: strong-to-weak power ratio above
    ``max_ratio_db``, or weak power less than ``margin_db`` above the strong trip's expected
    leakage through the notch (or not positive)."""
    strong_p = np.where(est["strong"] == 1, est["P1"], est["P2"])
    weak_p = np.where(est["strong"] == 1, est["P2"], est["P1"])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = 10 * np.log10(strong_p / weak_p)
        margin = 10 * np.log10(weak_p / est["leak"])
    return ~(ratio <= max_ratio_db) | ~(margin >= margin_db)


class SZ2Processor(Censoring, Block):
    """SZ-2: reflectivity, velocity and width of two overlaid trips of an SZ(8/64)-coded scan.

    See :mod:`pasim_blocks.processing.sz2` for the algorithm. Trip 1's moments are reported
    at the gates nearer than the unambiguous range c T / 2, trip 2's at their own range
    beyond it (on the truth's range grid); the weak trip's width is not estimated (NaN).
    """

    iq = Input(IQ, doc="received I/Q of a phase-coded scan")
    noise_power = Input(NOISE_POWER, doc="noise power per channel")
    calibration = Input(CALIBRATION, doc="radar constant and gate ranges")
    beams = Input(BEAMS, doc="beam geometry, PRT and transmit phases")
    moments = Output(
        MOMENTS, store="moments", doc="estimated moments", fields=("DBZH", "VRADH", "WRADH")
    )

    max_power_ratio_db = Param(
        60.0,
        units="dB",
        min=0.0,
        max=100.0,
        doc="censor the weak trip where the strong-to-weak power ratio exceeds this",
    )

    min_weak_to_leakage_db = Param(
        10.0,
        units="dB",
        min=-20.0,
        max=60.0,
        doc="censor the weak trip where its power over the strong trip's expected leakage "
        "through the notch is below this",
    )

    def setup(self) -> None:
        self._threshold_db = thresholds(self.p)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        iq, noise, cal, beams = (inputs[k] for k in ("iq", "noise_power", "calibration", "beams"))
        pulses = iq.shape[2]
        psi = transmit_phase(beams, pulses)
        if psi is None:
            raise ValueError(
                "the scan transmits no phase code: processor.sz2 needs scan.ppi's phase_code "
                "(sz8_64 or random)"
            )
        if "prt_ratio" in beams:
            raise ValueError("processor.sz2 needs a uniform PRT (the scan is staggered)")
        if pulses < 8:
            raise ValueError(f"SZ-2 needs at least 8 pulses per dwell, got {pulses}")
        prt = float(beams["prt"].values[0])
        lam = float(cal.attrs["wavelength_m"])
        rng = cal["range"].values
        gate_m = float(rng[1] - rng[0]) if rng.size > 1 else 1.0
        r_a = SPEED_OF_LIGHT * prt / 2
        n_a = round(r_a / gate_m)
        near = np.flatnonzero(rng < r_a)
        n_b, n_g = iq.shape[:2]
        out = {k: np.full((n_b, n_g), np.nan) for k in ("S_H", "VRADH", "WRADH")}
        snr_power = np.full((n_b, n_g), np.nan)
        ratio_db = float(self.p["max_power_ratio_db"])
        margin_db = float(self.p["min_weak_to_leakage_db"])
        noise_h = np.array(noise[..., 0], dtype=np.float64)
        for i in range(n_b):
            x = iq[i, near, :, 0].astype(np.complex128)
            est = separate_trips(x, psi[i], noise[i, near, 0], prt, lam)
            too_weak = weak_censored(est, ratio_db, margin_db)
            for trip, gates in ((1, near), (2, near + n_a)):
                ok = gates < n_g
                g = gates[ok]
                weak = est["strong"][ok] != trip
                p = est[f"P{trip}"][ok]
                v = np.where(weak & too_weak[ok], np.nan, est[f"V{trip}"][ok])
                out["S_H"][i, g] = p
                out["VRADH"][i, g] = v
                out["WRADH"][i, g] = est[f"W{trip}"][ok]
                snr_power[i, g] = np.where(weak & too_weak[ok], np.nan, p)
                noise_h[i, g] = noise[i, near[ok], 0]
        # A censored weak trip keeps its power (reflectivity) only where it is not swamped.
        out["S_H"] = np.where(np.isfinite(snr_power) | ~np.isfinite(out["S_H"]), out["S_H"], np.nan)
        ds = moments_dataset(
            out,
            noise_h,
            cal,
            chunk,
            self._threshold_db,
            lam / (4 * prt),
            {"transmission": "shv", "phidp_period_deg": 360.0},
            snr_power=snr_power,
            beyond_unambiguous=True,
        )
        return {"moments": ds}
