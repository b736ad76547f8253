"""Rain on the path: KDP from the truth's PHIDP, and the power laws of specific attenuation.

At the simulated radar's frequency f, from the truth measured at f_t:

- KDP scales with frequency: KDP(f) = KDP(f_t) f / f_t. In the Rayleigh regime the forward
  amplitudes of a drop go as 1 / lambda^2 and KDP = (180 / pi) lambda Re int (f_hh - f_vv)
  N(D) dD, so KDP goes as 1 / lambda (Bringi and Chandrasekar 2001, ch. 7; to first order:
  resonant drops at C and X band depart from it).
- A_H = alpha KDP^b (dB/km, H) and A_DP = A_H - A_V = beta KDP^d (dB/km), KDP in deg/km
  at f. The coefficients (:data:`COEFFICIENTS`) are linear (b = d = 1), the form of Bringi et
  al. (1990, JTECH 7) and Carey et al. (2000, JAM 39). alpha and beta are the middles of the
  ranges Bringi and Chandrasekar (2001, ch. 7) give for rain at each band, as the project's
  design notes (section 10) summarise them; the C-band alpha is within 15 % of the 0.08
  dB/deg that wradlib takes from Carey et al. (2000) for tropical rain. Between the table's
  frequencies alpha and beta are interpolated linearly in log alpha over log f; from 2 GHz
  to the S row and from the X row to 12 GHz they are held at the end rows; outside 2-12 GHz
  there is no coefficient and propagation is refused.

The truth (a NEXRAD sweep) carries PHIDP, not KDP: :func:`kdp_from_phidp` derives it as half
the range derivative of PHIDP, smoothed (a median filter, then a least-squares slope over a
window, scipy's Savitzky-Golay filter of order 1, that is a moving mean), on the gates with a
usable PHIDP, gaps filled along the radial, unwrapped (PHIDP is reported modulo 360 deg),
made non-decreasing along the radial (its running maximum), then differentiated. Usable:
echo of at least :data:`MIN_DBZ` (weaker echo's PHIDP is mostly noise), rho_hv at least a
threshold, and a PHIDP texture (its standard deviation over the :data:`TEXTURE_GATES` around
the gate) under :data:`TEXTURE_DEG`: ground clutter near the radar and noise have rho_hv
near 1 at some gates but a PHIDP that jumps by tens of degrees from gate to gate, where
rain's varies by a few.
So KDP >= 0: a negative KDP in rain is noise of the derivative, and a negative attenuation
would amplify; clipping the noisy derivative at 0 instead would keep its positive half, which
adds up along the path (about 5 dB too much two-way at C band over 200 km of the bundled
squall line, measured).
"""

from __future__ import annotations

import numpy as np

#: Power laws of rain at each band's table frequency: (frequency Hz, alpha dB/deg, b,
#: beta dB/deg, d); A_H = alpha KDP^b, A_DP = beta KDP^d with KDP in deg/km at that frequency.
#: Sources in the module docstring.
COEFFICIENTS: dict[str, tuple[float, float, float, float, float]] = {
    "S": (2.8e9, 0.0175, 1.0, 0.0035, 1.0),
    "C": (5.6e9, 0.07, 1.0, 0.015, 1.0),
    "X": (9.4e9, 0.275, 1.0, 0.04, 1.0),
}
#: Frequencies with coefficients (Hz): the S to X bands (IEEE letter bands).
COVERED_HZ = (2e9, 12e9)
#: Weakest echo (dBZ) whose PHIDP enters the KDP fit.
MIN_DBZ = 10.0
#: PHIDP texture: gates of the window and the largest standard deviation (deg) of a usable gate.
TEXTURE_GATES = 9
TEXTURE_DEG = 10.0
#: IEEE radar letter bands (GHz), to tell whether two frequencies are in one band.
BANDS = (("L", 1.0, 2.0), ("S", 2.0, 4.0), ("C", 4.0, 8.0), ("X", 8.0, 12.0), ("Ku", 12.0, 18.0))


def band(frequency_hz: float) -> str:
    """IEEE letter band of a frequency ('' outside L to Ku)."""
    ghz = frequency_hz / 1e9
    return next((name for name, lo, hi in BANDS if lo <= ghz < hi), "")


def coefficients(frequency_hz: float) -> tuple[float, float, float, float]:
    """(alpha, b, beta, d) at a frequency in :data:`COVERED_HZ` (module docstring's rule)."""
    lo, hi = COVERED_HZ
    if not lo <= frequency_hz <= hi:
        raise ValueError(
            f"no rain attenuation coefficients at {frequency_hz / 1e9:g} GHz (only "
            f"{lo / 1e9:g} to {hi / 1e9:g} GHz, S to X band)"
        )
    rows = np.array(sorted(COEFFICIENTS.values()))
    x = np.log(np.clip(frequency_hz, rows[0, 0], rows[-1, 0]))
    log_f = np.log(rows[:, 0])
    alpha = float(np.exp(np.interp(x, log_f, np.log(rows[:, 1]))))
    beta = float(np.exp(np.interp(x, log_f, np.log(rows[:, 3]))))
    return (
        alpha,
        float(np.interp(x, log_f, rows[:, 2])),
        beta,
        float(np.interp(x, log_f, rows[:, 4])),
    )


def kdp_from_phidp(
    phidp_deg: np.ndarray,
    dbz: np.ndarray,
    rhohv: np.ndarray | None,
    gate_m: float,
    window_m: float,
    min_rhohv: float,
) -> np.ndarray:
    """KDP (deg/km, >= 0) on a radial x gate grid from PHIDP (deg): 0 where there is no echo
    (DBZH NaN) and on radials with fewer usable gates than the window holds."""
    # Weak echo's PHIDP is mostly noise (and at NEXRAD's 0-360 deg it wraps from just
    # below the offset to near 360): it does not enter the fit.
    usable = np.isfinite(phidp_deg) & (np.nan_to_num(dbz, nan=-999.0) >= MIN_DBZ)
    if rhohv is not None:
        usable &= np.nan_to_num(rhohv, nan=0.0) >= min_rhohv
    usable &= texture(phidp_deg, usable) <= TEXTURE_DEG
    n_gates = phidp_deg.shape[1]
    # An odd window of at least 3 gates, no longer than the radial.
    window = int(min(max(3, round(window_m / gate_m) // 2 * 2 + 1), n_gates // 2 * 2 - 1))
    filled = np.zeros(phidp_deg.shape)
    enough = usable.sum(axis=1) >= window
    gates = np.arange(n_gates)
    for i in np.flatnonzero(enough):
        # Unusable gates take the PHIDP of their usable neighbours (held at the ends): the
        # phase a gap adds shows on the far side, as the derivative across the gap.
        filled[i] = np.interp(gates, gates[usable[i]], phidp_deg[i, usable[i]])
    # PHIDP is reported modulo 360 deg: a step of more than 180 deg between neighbours is a
    # wrap, not propagation (rain adds a few degrees per gate at most).
    filled = np.unwrap(filled, period=360.0, axis=1)
    # scipy is imported where it is used: importing it at the top made every command that
    # only reads a graph (validate, blocks, --help) pay for it.
    from scipy.ndimage import median_filter
    from scipy.signal import savgol_filter

    # The median removes isolated spikes (clutter, second trips) the slope would spread.
    filled = median_filter(filled, size=(1, max(3, window // 4 * 2 + 1)), mode="nearest")
    smooth = savgol_filter(filled, window, 1, axis=1, mode="nearest")
    # PHIDP made non-decreasing along the radial before the derivative: KDP >= 0 without
    # clipping a noisy derivative, whose positive half alone would add up along the path.
    kdp = 0.5 * np.gradient(np.maximum.accumulate(smooth, axis=1), gate_m / 1e3, axis=1)
    return np.where(enough[:, None] & np.isfinite(dbz), kdp, 0.0)


def texture(phidp_deg: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """Standard deviation of PHIDP over the usable gates of a window around each gate (inf
    where fewer than half the window's gates are usable)."""
    w = usable.astype(np.float64)
    x = np.where(usable, phidp_deg, 0.0)
    from scipy.ndimage import uniform_filter1d

    count = uniform_filter1d(w, TEXTURE_GATES, axis=1, mode="constant") * TEXTURE_GATES
    mean = uniform_filter1d(x, TEXTURE_GATES, axis=1, mode="constant") * TEXTURE_GATES
    square = uniform_filter1d(x**2, TEXTURE_GATES, axis=1, mode="constant") * TEXTURE_GATES
    with np.errstate(divide="ignore", invalid="ignore"):
        m = mean / count
        var = np.maximum(square / count - m**2, 0.0)
    return np.where(count >= TEXTURE_GATES / 2, np.sqrt(var), np.inf)
