"""Staggered-PRT processing: velocity dealiasing on the extended Nyquist interval.

Torres, S. M., Y. F. Dubel and D. S. Zrnic (2004), *Design, implementation, and
demonstration of a staggered PRT algorithm for the WSR-88D*, J. Atmos. Oceanic Technol. 21,
1389-1399 (after Sirmans, Zrnic and Bumgarner 1976 and Zrnic and Mahapatra 1985). Pulses
alternate T1, T2 apart, T1 / T2 = m / n (2/3 or 3/4). The autocorrelations at the two lags,

    R(T1) = < x*_2k x_2k+1 >,   R(T2) = < x*_2k+1 x_2k+2 >,

give two aliased velocities v_i = -lambda / (4 pi T_i) arg R(T_i) with Nyquist velocities
v_a,i = lambda / (4 T_i). On the extended interval +-v_e, v_e = m v_a1 = n v_a2 =
lambda / (4 (T2 - T1)), each true velocity folds into a pair (P, Q) of Nyquist intervals and
the difference v1 - v2 takes one of a few levels 2 Q v_a2 - 2 P v_a1; the dealiasing rule
picks the level nearest the measured difference and unfolds v1 by its P: v = v1 + 2 P v_a1
(the T1 estimate, unfolded). Power is the noise-corrected lag-0 of all pulses; width the
ratio estimator of the two lags (noise-free to first order), for a Gaussian spectrum

    sigma_v = lambda / (2 sqrt(2) pi sqrt(T2^2 - T1^2)) sqrt(ln(|R(T1)| / |R(T2)|)),

and the polarimetric moments the lag-0 ones of the uniform processor.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from pasim_graph import Chunk

from ..timing import cohere_first_trip, prt_ratio
from .moment_processor import MomentProcessor
from .pulse_pair import correlations, moments_from_correlations


def dealiasing_rules(ratio: Fraction) -> tuple[np.ndarray, np.ndarray]:
    """The velocity-difference levels (in units of v_a1) and the fold number P of v1 of each.

    Enumerated by sweeping the extended interval: the (P, Q) pairs a true velocity there
    can fold into, each giving the level 2 Q v_a2 - 2 P v_a1 of v1 - v2.
    """
    m = ratio.numerator
    va2 = float(ratio)  # v_a2 / v_a1 = T1 / T2
    step = 2 * m / 20_000
    v = np.arange(-m + step / 2, m, step)  # in units of v_a1, never on a fold boundary
    p = np.floor((v + 1) / 2)  # v1 = v - 2 P v_a1 in [-v_a1, v_a1)
    q = np.floor((v / va2 + 1) / 2)
    pairs = np.unique(np.stack([p, q], axis=1), axis=0)
    levels = 2 * pairs[:, 1] * va2 - 2 * pairs[:, 0]
    if np.unique(np.round(levels, 9)).size != levels.size:  # pragma: no cover
        raise ValueError(f"PRT ratio {ratio}: the velocity-difference rule is ambiguous")
    return levels, pairs[:, 0]


def staggered_correlations(iq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R(T1) and R(T2) along the last (pulse) axis: pulses 0, 1, 2, ... alternate T1, T2."""
    even, odd = iq[..., 0::2], iq[..., 1::2]
    r1 = np.mean(np.conj(even[..., : odd.shape[-1]]) * odd, axis=-1)
    n2 = min(odd.shape[-1], even.shape[-1] - 1)
    r2 = np.mean(np.conj(odd[..., :n2]) * even[..., 1 : n2 + 1], axis=-1)
    return r1, r2


def staggered_velocity_width(
    r1: np.ndarray, r2: np.ndarray, t1_s: float, ratio: Fraction, wavelength_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Dealiased velocity and width from R(T1), R(T2) (see the module's documentation)."""
    t2 = t1_s / float(ratio)
    va1 = wavelength_m / (4 * t1_s)
    v1 = -wavelength_m / (4 * np.pi * t1_s) * np.angle(r1)
    v2 = -wavelength_m / (4 * np.pi * t2) * np.angle(r2)
    levels, folds = dealiasing_rules(ratio)
    diff = (v1 - v2) / va1
    pick = np.argmin(np.abs(diff[..., None] - levels), axis=-1)
    extended = ratio.numerator * va1
    # Wrapped onto +-v_e: a velocity at the interval's end may unfold just beyond it.
    velocity = np.mod(v1 + 2 * folds[pick] * va1 + extended, 2 * extended) - extended
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(np.abs(r1) / np.abs(r2))
    width = (
        wavelength_m
        / (2 * np.sqrt(2) * np.pi * np.sqrt(t2**2 - t1_s**2))
        * np.sqrt(np.maximum(log_ratio, 0))
    )
    return velocity, width


class StaggeredPrtProcessor(MomentProcessor):
    """Moments of a staggered-PRT dwell (scan.ppi's ``stagger``), Torres et al. (2004).

    Velocity dealiased on the extended Nyquist interval lambda / (4 (T2 - T1)) by the
    velocity-difference rule, width from the two lags' ratio, power and polarimetric
    moments from all pulses (:mod:`pasim_blocks.processing.staggered`). The Nyquist
    velocity reported (and scored on) is the extended one. A phase-coded scan is cohered to
    the first trip first, as ``processor.pulse_pair`` does.
    """

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        d = self.dwell(inputs, chunk)
        iq, noise, beams = d.iq, d.noise, d.beams
        ratio = prt_ratio(beams)
        if ratio is None:
            raise ValueError(
                "the scan's PRT is uniform: processor.staggered needs scan.ppi's stagger "
                "(2/3 or 3/4); use processor.pulse_pair for a uniform PRT"
            )
        if chunk.expected:
            raise ValueError(
                f"block '{self.name}': a staggered dwell needs pulses; the weather channel's "
                "method 'expected' draws none: run it at a level that draws them (combined "
                "or slower)"
            )
        if iq.shape[2] < 3:
            raise ValueError(
                f"a staggered dwell needs at least 3 pulses (one T1 and one T2 pair), got "
                f"{iq.shape[2]}"
            )
        iq = cohere_first_trip(iq, beams)
        t1, lam, dual = d.prt_s, d.wavelength_m, d.dual
        corr = correlations(iq[..., 0], iq[..., 1] if dual else None, doppler=False)
        est = moments_from_correlations(corr, noise[..., 0], noise[..., 1], t1, lam)
        if chunk.wants("VRADH", "WRADH"):
            r1, r2 = staggered_correlations(iq[..., 0].astype(np.complex128))
            v, w = staggered_velocity_width(r1, r2, t1, ratio, lam)
            ok = (est["S_H"] > 0) & (np.abs(r1) > 0) & (np.abs(r2) > 0)
            est["VRADH"] = np.where(ok, v, np.nan)
            est["WRADH"] = np.where(ok, w, np.nan)
        extended = lam / (4 * (t1 / float(ratio) - t1))
        return self.moments_output(est, noise[..., 0], d, chunk, extended)
