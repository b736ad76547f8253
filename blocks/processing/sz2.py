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
   width and the window's sidelobes, swamps the weak trip), where its power is less than
   ``min_weak_to_leakage_db`` above that leakage (plus, with ``code_leakage_db``, the white
   leakage of the transmitter's code errors: scan.ppi ``phase_code_error_deg``), or where
   its SNR is below the Doppler threshold. Each trip's moments go to its own range: trip
   2's at r + c T / 2.

Reflectivity, velocity and width are estimated on the H channel. In dual polarisation
(the WSR-88D's SZ-2 takes them from the long-PRT surveillance scan instead), each trip's ZDR,
rho_hv and phi_DP are estimated as well:

5. Strong trip: from the lag-1 correlations of its cohered H and V series (Melnikov and
   Zrnic 2007, :func:`polarimetry_lag1`), which the weak trip (white once cohered to the
   strong one) and the noise leave unbiased.
6. Weak trip: V goes through the same cohering, notch (centred on H's strong trip) and
   re-cohering as H. ZDR, rho_hv and phi_DP then come from the lag-0 powers and H-V cross
   power of what the notch left (times 4), less the noise and the strong trip's expected
   leakage. They are censored where the weak trip's velocity is, and where its SNR is below
   ``min_weak_snr_polarimetric_db`` (15 dB). The notch leaves a quarter of the weak trip's
   spectrum, so its estimates rest on fewer independent samples than the strong trip's.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import scipy.signal

from pasim_graph import Chunk, Output, Param
from pasim_graph.fm301 import POLARIMETRIC_FIELDS

from ..signals import MOMENTS, SPEED_OF_LIGHT
from ..timing import transmit_phase
from .gmap import clutter_shape
from .moment_processor import MomentProcessor

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
    x: np.ndarray,
    psi: np.ndarray,
    noise_w: np.ndarray,
    prt_s: float,
    wavelength_m: float,
    xv: np.ndarray | None = None,
    noise_v: np.ndarray | None = None,
    code_leakage: float = 0.0,
) -> dict[str, np.ndarray]:
    """SZ-2 estimates of two overlaid trips from series ``x`` (gate x pulse) transmitted with
    phases ``psi`` (pulse, rad); ``noise_w`` per gate.

    Returns per gate: ``strong`` (1 or 2), and for ``1`` and ``2`` the power (W), velocity
    and width (m/s) of that trip (``P1``, ``V1``, ``W1``, ``P2``, ...), the weak trip's width
    NaN where not estimated. With the V series ``xv`` (and its noise ``noise_v``), also each
    trip's ZDR (dB), rho_hv and phi_DP (deg) (``ZDR1``, ``RHOHV1``, ``PHIDP1``, ...; see
    :func:`polarimetry`). ``code_leakage`` is the fraction of the strong trip's power that
    the transmitter's code errors spread white over the spectrum (0: an ideal code); it is
    added to the expected leakage through the notch.
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
    if code_leakage:
        # White: the notch passes 1/4 of it, as of the weak trip, so it counts in full.
        leak = leak + code_leakage
    leak_w = leak * np.maximum(total, 0) / (1 + leak)
    p_w = kept / (1 - NOTCH_FRACTION) - noise_w - leak_w
    p_s = total - np.maximum(p_w, 0)
    r1_w = lag(yw, 1)
    v_w = k_vel * np.angle(r1_w)
    first = strong == 0
    out = {
        "strong": strong + 1,
        "leak": leak_w,
        "P1": np.where(first, p_s, p_w),
        "P2": np.where(first, p_w, p_s),
        "V1": np.where(first, v_s, v_w),
        "V2": np.where(first, v_w, v_s),
        "W1": np.where(first, w_s, np.nan),
        "W2": np.where(first, np.nan, w_s),
    }
    if xv is None:
        return out
    noise_v = np.zeros(x.shape[0]) if noise_v is None else noise_v
    # V through the same cohering, notch (centred on H's strong trip) and re-cohering.
    xs_v = xv * np.where(pick, c[0], c[1])
    yw_v = np.fft.ifft(np.where(keep, np.fft.fft(xs_v * win, axis=-1), 0), axis=-1) * switch
    total_v = np.mean(np.abs(xv) ** 2, axis=-1) - noise_v
    p_wv = (
        np.mean(np.abs(yw_v) ** 2, axis=-1) / mean_w2 / (1 - NOTCH_FRACTION)
        - noise_v
        - leak * np.maximum(total_v, 0) / (1 + leak)
    )
    cross = np.mean(np.conj(x) * xv, axis=-1)
    c_w = np.mean(np.conj(yw) * yw_v, axis=-1) / mean_w2 / (1 - NOTCH_FRACTION)
    with np.errstate(invalid="ignore"):  # gates without echo: no width, no leakage
        c_w = c_w - leak * cross / (1 + leak)
    weak = polarimetry_lag0(p_w, p_wv, c_w)
    strong_pol = polarimetry_lag1(xs, xs_v)
    for k in ("ZDR", "RHOHV", "PHIDP"):
        out[f"{k}1"] = np.where(first, strong_pol[k], weak[k])
        out[f"{k}2"] = np.where(first, weak[k], strong_pol[k])
    return out


def polarimetry_lag1(xh: np.ndarray, xv: np.ndarray) -> dict[str, np.ndarray]:
    """ZDR (dB), rho_hv, phi_DP (deg) of the trip the series are cohered to, from lag-1
    correlations (Melnikov and Zrnic 2007): the other trip, spread by the switching code,
    and the noise are white and add nothing to lag 1. With R_h(1) = <h*_m h_m+1>, R_v(1),
    C_hv = <h*_m v_m+1> and C_vh = <v*_m h_m+1>: Z_dr = |R_h(1)| / |R_v(1)|, rho_hv =
    (|C_hv| + |C_vh|) / (2 sqrt(|R_h(1)| |R_v(1)|)), phi_DP = arg(C_hv R_h(1)* / |R_h(1)| +
    R_v(1) C_vh* / |R_v(1)|) (each term is e^(j phi_DP) times a positive number)."""
    r_h, r_v = lag(xh, 1), lag(xv, 1)
    c_hv = np.mean(np.conj(xh[..., :-1]) * xv[..., 1:], axis=-1)
    c_vh = np.mean(np.conj(xv[..., :-1]) * xh[..., 1:], axis=-1)
    a_h, a_v = np.abs(r_h), np.abs(r_v)
    with np.errstate(divide="ignore", invalid="ignore"):
        zdr = 10 * np.log10(a_h / a_v)
        rho = (np.abs(c_hv) + np.abs(c_vh)) / (2 * np.sqrt(a_h * a_v))
        phase = np.angle(c_hv * np.conj(r_h) / a_h + r_v * np.conj(c_vh) / a_v)
    return {"ZDR": zdr, "RHOHV": rho, "PHIDP": np.mod(np.rad2deg(phase), 360.0)}


def polarimetry_lag0(p_h: np.ndarray, p_v: np.ndarray, c_hv: np.ndarray) -> dict[str, np.ndarray]:
    """ZDR (dB), rho_hv, phi_DP (deg) from noise- and leakage-corrected powers and the H-V
    cross power (NaN where a power is not positive)."""
    ok = (p_h > 0) & (p_v > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        zdr = np.where(ok, 10 * np.log10(p_h / p_v), np.nan)
        rho = np.where(ok, np.abs(c_hv) / np.sqrt(p_h * p_v), np.nan)
    phase = np.where(ok, np.mod(np.rad2deg(np.angle(c_hv)), 360.0), np.nan)
    return {"ZDR": zdr, "RHOHV": rho, "PHIDP": phase}


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


class SZ2Processor(MomentProcessor):
    """SZ-2: reflectivity, velocity and width of two overlaid trips of an SZ(8/64)-coded scan.

    See :mod:`pasim_blocks.processing.sz2` for the algorithm. Trip 1's moments are reported
    at the gates nearer than the unambiguous range c T / 2, trip 2's at their own range
    beyond it (on the truth's range grid); the weak trip's width is not estimated (NaN). In
    dual polarisation both trips' ZDR, rho_hv and phi_DP are estimated too; the weak trip's
    are censored where its velocity is, or where its SNR is below
    ``min_weak_snr_polarimetric_db``.
    """

    moments = Output(
        MOMENTS,
        store="moments",
        doc="estimated moments",
        fields=("DBZH", "VRADH", "WRADH", *POLARIMETRIC_FIELDS),
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

    min_weak_snr_polarimetric_db = Param(
        15.0,
        units="dB",
        min=-20.0,
        max=60.0,
        doc="censor the weak trip's ZDR, rho_hv and phi_DP where its SNR is below this (the "
        "notch leaves a quarter of its spectrum: fewer independent samples than the strong "
        "trip's)",
    )

    code_leakage_db = Param(
        None,
        units="dB",
        optional=True,
        min=-120.0,
        max=0.0,
        doc="the strong trip's power the transmitter's code errors spread white, over its "
        "own (about 10 log10 of the phase error's variance in rad^2: -41 dB for 0.5 deg "
        "rms), counted in the weak trip's censoring; unset: an ideal code",
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        d = self.dwell(inputs, chunk)
        iq, noise, cal, beams = d.iq, d.noise, d.calibration, d.beams
        if chunk.expected:
            raise ValueError(
                f"block '{self.name}': SZ-2 needs coded pulses; the weather channel's method "
                "'expected' draws none: run it at a level that draws them (combined or slower)"
            )
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
        prt, lam = d.prt_s, d.wavelength_m
        rng = cal["range"].values
        gate_m = float(rng[1] - rng[0]) if rng.size > 1 else 1.0
        r_a = SPEED_OF_LIGHT * prt / 2
        n_a = round(r_a / gate_m)
        near = np.flatnonzero(rng < r_a)
        n_b, n_g = iq.shape[:2]
        dual = d.dual and iq.shape[-1] > 1
        names = ("S_H", "VRADH", "WRADH", *(POLARIMETRIC_FIELDS if dual else ()))
        out = {k: np.full((n_b, n_g), np.nan) for k in names}
        pol_db = float(self.p["min_weak_snr_polarimetric_db"])
        snr_power = np.full((n_b, n_g), np.nan)
        ratio_db = float(self.p["max_power_ratio_db"])
        margin_db = float(self.p["min_weak_to_leakage_db"])
        floor_db = self.p["code_leakage_db"]
        code_leakage = 0.0 if floor_db is None else 10 ** (float(floor_db) / 10)
        noise_h = np.array(noise[..., 0], dtype=np.float64)
        for i in range(n_b):
            x = iq[i, near, :, 0].astype(np.complex128)
            xv = iq[i, near, :, 1].astype(np.complex128) if dual else None
            est = separate_trips(
                x, psi[i], noise[i, near, 0], prt, lam, xv, noise[i, near, 1], code_leakage
            )
            too_weak = weak_censored(est, ratio_db, margin_db)
            with np.errstate(divide="ignore", invalid="ignore"):
                weak_snr = 10 * np.log10(
                    np.where(est["strong"] == 1, est["P2"], est["P1"]) / noise[i, near, 0]
                )
            pol_censored = too_weak | ~(weak_snr >= pol_db)
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
                for k in POLARIMETRIC_FIELDS if dual else ():
                    out[k][i, g] = np.where(weak & pol_censored[ok], np.nan, est[f"{k}{trip}"][ok])
                noise_h[i, g] = noise[i, near[ok], 0]
        # A censored weak trip keeps its power (reflectivity) only where it is not swamped.
        out["S_H"] = np.where(np.isfinite(snr_power) | ~np.isfinite(out["S_H"]), out["S_H"], np.nan)
        return self.moments_output(
            out,
            noise_h,
            d,
            chunk,
            lam / (4 * prt),
            snr_power=snr_power,
            beyond_unambiguous=True,
        )
