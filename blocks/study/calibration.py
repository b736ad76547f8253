"""The ZDR bias along azimuth against the antenna's two-way H/V ratio (paper figures 9e-11e).

A planar array's H and V patterns differ more and more off broadside, so with one radar
constant for every beam (``calibration: boresight``) its ZDR bias follows the two-way H/V
power ratio of each beam; a cylinder's beam is always formed at the broadside of its active
sector, so its ratio, and its bias, stay flat; a radar constant per beam from the beam's own
two-way pattern (``calibration: per_beam``) removes the ratio. The study runs every system
whose antenna offers the choice under both calibrations (:mod:`.plan`); here each run's ZDR
error against the raw gates is averaged along range, beam by beam, and set against the ratio
the study measured from the pattern (:mod:`.patterns`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: A beam's average needs this many scored gates (fewer: NaN, left out of the statistics).
MIN_GATES = 10
#: A ratio whose std along azimuth is below this is flat (a tenth of the 0.1 dB to which ZDR
#: is calibrated): a profile's correlation with it, or slope on it, would mean nothing.
FLAT_RATIO_DB = 0.01


def azimuth_profile(error: np.ndarray) -> np.ndarray:
    """Mean of each beam's finite errors (beam, range); NaN for beams with too few."""
    ok = np.isfinite(error)
    n = ok.sum(axis=1)
    s = np.where(ok, error, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n >= MIN_GATES, s / np.maximum(n, 1), np.nan)


def against_ratio(profile: np.ndarray, ratio: np.ndarray) -> dict[str, Any]:
    """How a ZDR-bias profile follows the H/V ratio: Pearson correlation, least-squares slope
    (dB of bias per dB of ratio), the profile's spread across azimuth and its mean; no
    correlation or slope against a flat ratio (:data:`FLAT_RATIO_DB`)."""
    ok = np.isfinite(profile) & np.isfinite(ratio)
    p, r = profile[ok], ratio[ok]
    out: dict[str, Any] = {
        "beams": int(ok.sum()),
        "mean_db": float(p.mean()) if p.size else math.nan,
        "azimuth_std_db": float(p.std(ddof=1)) if p.size > 1 else math.nan,
        "correlation": math.nan,
        "slope": math.nan,
    }
    if p.size > 2 and p.std() > 0 and r.std(ddof=1) >= FLAT_RATIO_DB:
        out["correlation"] = float(np.corrcoef(p, r)[0, 1])
        out["slope"] = float(np.polyfit(r, p, 1)[0])
    return out


def zdr_calibration(
    own: str, profiles: dict[str, np.ndarray], azimuth: np.ndarray, ratio: np.ndarray
) -> dict[str, Any]:
    """The ``calibration`` entry of a point's ZDR scores: the azimuth profiles of the ZDR error
    under each calibration, the two-way H/V ratio, and how each profile follows it."""
    return {
        "own": own,
        "azimuth_deg": [float(a) for a in azimuth],
        "hv_ratio_db": [float(x) for x in ratio],  # relative to the broadside ratio
        "hv_ratio_std_db": float(np.nanstd(ratio, ddof=1)) if ratio.size > 1 else math.nan,
        "hv_ratio_flat": bool(np.nanstd(ratio, ddof=1) < FLAT_RATIO_DB) if ratio.size > 1 else True,
        "profiles_db": {k: [float(x) for x in v] for k, v in profiles.items()},
        "against_ratio": {k: against_ratio(v, ratio) for k, v in profiles.items()},
    }
