"""The transmitted spectrum against the NTIA Radar Spectrum Engineering Criteria (RSEC).

The radiated pulse train's power spectral density is a line spectrum at the PRF's multiples
whose envelope is the energy spectrum of one radiated pulse, |X(f)|^2 / PRT. Relative to its
peak (as the criteria state their mask) only that envelope matters, so :func:`power_spectrum`
returns |X(f)|^2 in dB below its maximum, from a zero-padded FFT of one pulse.

The criteria (NTIA Manual of Regulations and Procedures for Federal Radio Frequency
Management, chapter 5, section 5.5) bound the -40 dB bandwidth of the emission and its
roll-off beyond it, per category of radar. The constants below were written from memory of
the criteria's text, not copied from it: the documentation search of this project found
reports about the RSEC (NTIA TR-05-420) but not the manual's formulas. Every constant below is
therefore marked *unverified*; ``docs/transceiver.md`` lists them. Two of them have an
independent check in theory: the non-FM limit 64 / t is the -40 dB bandwidth of an ideal
rectangular pulse (the sinc^2 envelope reaches -40 dB at 1 / (pi f t) = 0.01, so B = 200 /
(pi t) = 63.7 / t), and K / sqrt(t_r t) is the asymptote of a trapezoidal pulse (its envelope
1 / (pi^2 f^2 t t_ramp) reaches -40 dB at B = 20 / (pi sqrt(t t_ramp)) = 6.37 / sqrt(t
t_ramp)), which K = 6.2 and 7.6 bracket.

Units of the criteria's formulas: B in MHz with t and t_r in microseconds; the functions here
take and return SI units (s, Hz).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

#: Criteria, as recalled (unverified; see the module docstring). ``k_high`` applies to radars
#: above 100 kW peak, ``k_low`` at or below; ``slope_db_per_decade`` is the roll-off from the
#: -40 dB points down to the spurious level ``spurious_db`` below the peak.
CRITERIA: dict[str, dict[str, float]] = {
    "B": {"k_high": 7.6, "k_low": 7.6, "slope_db_per_decade": 20.0, "spurious_db": 60.0},
    "C": {"k_high": 6.2, "k_low": 7.6, "slope_db_per_decade": 20.0, "spurious_db": 60.0},
    "D": {"k_high": 6.2, "k_low": 7.6, "slope_db_per_decade": 40.0, "spurious_db": 60.0},
}
#: The non-FM cap 64 / t (MHz, t in us): the -40 dB bandwidth of a rectangular pulse.
RECT_CAP = 64.0
#: Peak power above which ``k_high`` applies (W).
HIGH_POWER_W = 100e3
#: The level the bandwidth is taken at (dB below the peak).
LEVEL_DB = -40.0


def power_spectrum(
    envelope: np.ndarray, sample_rate_hz: float, pad: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz, ascending, centred on the carrier) and |X(f)|^2 in dB below its peak.

    The FFT is zero-padded to at least ``pad`` times the pulse (a power of two), so the
    spectrum is sampled ``pad`` times finer than 1 / pulse length.
    """
    x = np.asarray(envelope, dtype=complex)
    n = 1 << int(np.ceil(np.log2(max(2, pad * x.size))))
    spec = np.abs(np.fft.fftshift(np.fft.fft(x, n))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(n, 1.0 / sample_rate_hz))
    peak = spec.max()
    if peak <= 0:
        raise ValueError("the radiated pulse is all zero: no spectrum")
    return f, 10 * np.log10(np.maximum(spec / peak, 1e-300))


def bandwidth_at(freq_hz: np.ndarray, level_db: np.ndarray, at_db: float = LEVEL_DB) -> dict:
    """The outermost crossings of ``at_db`` (linear interpolation in dB between samples).

    Returns ``low_hz``, ``high_hz`` and ``bandwidth_hz`` (their difference): the frequencies
    beyond which the spectrum stays below ``at_db`` up to the ends of the computed span.
    """
    above = np.flatnonzero(level_db >= at_db)
    if above.size == 0:
        raise ValueError(f"the spectrum never reaches {at_db:g} dB")
    lo, hi = above[0], above[-1]
    if lo == 0 or hi == level_db.size - 1:
        raise ValueError(
            f"the spectrum is above {at_db:g} dB at the edge of the computed span "
            f"(+-{freq_hz[-1] / 1e6:.4g} MHz): raise the analysis sample rate"
        )

    def cross(i_out: int, i_in: int) -> float:
        y0, y1 = level_db[i_out], level_db[i_in]
        return float(freq_hz[i_out] + (at_db - y0) / (y1 - y0) * (freq_hz[i_in] - freq_hz[i_out]))

    low, high = cross(lo - 1, lo), cross(hi + 1, hi)
    return {"low_hz": low, "high_hz": high, "bandwidth_hz": high - low}


def rise_fall_times(envelope: np.ndarray, sample_rate_hz: float) -> tuple[float, float]:
    """10-90 % rise and 90-10 % fall times of the envelope's amplitude (s), interpolated.

    Measured on the leading edge (first crossings of 10 % and 90 % of the peak amplitude)
    and the trailing edge (last crossings). An edge sharper than one sample gives 0.
    """
    a = np.abs(np.asarray(envelope))
    a = a / a.max()
    t = np.arange(a.size) / sample_rate_hz

    def first(level: float, arr: np.ndarray, times: np.ndarray) -> float:
        i = int(np.argmax(arr >= level))
        if i == 0:
            return float(times[0])
        return float(
            times[i - 1] + (level - arr[i - 1]) / (arr[i] - arr[i - 1]) * (times[i] - times[i - 1])
        )

    rise = first(0.9, a, t) - first(0.1, a, t)
    rev, trev = a[::-1], -t[::-1]
    fall = first(0.9, rev, trev) - first(0.1, rev, trev)
    return max(0.0, rise), max(0.0, fall)


@dataclass
class Criteria:
    """The RSEC figures that apply to one radar and waveform."""

    category: str
    k: float
    slope_db_per_decade: float
    spurious_db: float
    bandwidth_40_hz: float  # the allowed -40 dB bandwidth
    formula: str


def rsec_criteria(
    category: str,
    width_s: float,
    rise_s: float,
    peak_power_w: float,
    chirp_hz: float | None = None,
) -> Criteria:
    """The allowed -40 dB bandwidth and roll-off for a category (B, C or D; unverified).

    Non-FM pulse: B(-40) = K / sqrt(t_r t) or 64 / t, whichever is less.
    FM (chirp) pulse of swept bandwidth B_c: B(-40) = K / sqrt(t_r t) + 2 B_c.
    t: pulse width (us); t_r: rise time (us; the shorter of rise and fall, 10-90 %);
    K: ``k_high`` above 100 kW peak, ``k_low`` otherwise.
    """
    if category not in CRITERIA:
        raise ValueError(f"RSEC category {category!r}: expected one of {', '.join(CRITERIA)}")
    if width_s <= 0:
        raise ValueError(f"pulse width {width_s:g} s must be positive")
    c = CRITERIA[category]
    k = c["k_high"] if peak_power_w > HIGH_POWER_W else c["k_low"]
    t_us, tr_us = width_s * 1e6, rise_s * 1e6
    rise_term = k / np.sqrt(tr_us * t_us) if tr_us > 0 else np.inf
    if chirp_hz is None:
        b_mhz = min(rise_term, RECT_CAP / t_us)
        formula = f"min({k:g}/sqrt(t_r t), 64/t)"
    else:
        if not np.isfinite(rise_term):
            raise ValueError(
                "the FM criterion K / sqrt(t_r t) + 2 B_c needs a rise time: the radiated "
                "pulse's edges are sharper than one sample (set the amplifier's rise_time_s)"
            )
        b_mhz = rise_term + 2 * chirp_hz / 1e6
        formula = f"{k:g}/sqrt(t_r t) + 2 B_c"
    return Criteria(
        category, k, c["slope_db_per_decade"], c["spurious_db"], float(b_mhz * 1e6), formula
    )


def mask_db(freq_hz: np.ndarray, criteria: Criteria) -> np.ndarray:
    """The emission mask (dB below the peak) against offset from the carrier.

    0 dB within +-B(-40)/2; beyond, -40 dB at the -40 dB points falling at the criteria's
    slope per decade of offset, down to the spurious level.
    """
    half = criteria.bandwidth_40_hz / 2
    off = np.abs(np.asarray(freq_hz, dtype=float))
    with np.errstate(divide="ignore"):
        roll = LEVEL_DB - criteria.slope_db_per_decade * np.log10(np.maximum(off, half) / half)
    return np.where(off <= half, 0.0, np.maximum(roll, -criteria.spurious_db))


def mask_span_hz(criteria: Criteria) -> float:
    """The offset at which the mask reaches the spurious level."""
    decades = (criteria.spurious_db + LEVEL_DB) / criteria.slope_db_per_decade
    return criteria.bandwidth_40_hz / 2 * 10**decades


def compliance(freq_hz: np.ndarray, level_db: np.ndarray, criteria: Criteria) -> dict[str, Any]:
    """Pass or fail of a spectrum against the mask, with the margin (dB; negative: fails).

    The margin is the least distance of the mask above the spectrum over the computed span,
    and ``worst_offset_hz`` where it occurs (|offset| beyond B(-40)/2 only: inside, the mask
    is the peak itself).
    """
    mask = mask_db(freq_hz, criteria)
    outside = np.abs(freq_hz) > criteria.bandwidth_40_hz / 2
    if not outside.any():
        raise ValueError("the computed span lies inside the allowed -40 dB bandwidth")
    gap = (mask - level_db)[outside]
    i = int(np.argmin(gap))
    return {
        "passes": bool(gap[i] >= 0),
        "margin_db": float(gap[i]),
        "worst_offset_hz": float(freq_hz[outside][i]),
    }
