"""What a beam may ask of a truth read for a sector only: its pattern must stay inside it."""

from __future__ import annotations

import numpy as np


def truth_span(az_truth: np.ndarray, width_deg: float) -> tuple[float, float] | None:
    """The azimuths a truth covers, as (start, extent) in deg clockwise (each radial counting
    for ``width_deg``), or None when it covers the whole circle."""
    az = np.sort(np.mod(az_truth, 360.0))
    if az.size < 2:
        return None
    gaps = np.diff(np.concatenate([az, [az[0] + 360.0]]))
    k = int(np.argmax(gaps))
    if gaps[k] <= 2.5 * width_deg:
        return None  # the whole circle
    start = float(az[(k + 1) % az.size] - width_deg / 2)
    return start % 360.0, float(360.0 - gaps[k] + width_deg)


def check_coverage(
    az_truth: np.ndarray, width_deg: float, az_beams: np.ndarray, support_deg: float
) -> None:
    """Refuse beams whose pattern reaches beyond a truth read for a sector only.

    A truth read for a sector (``truth.azimuth_start_deg``) or from a file that covers a
    sector only ends somewhere; a beam whose pattern grid reaches past that end would
    silently miss the echo there.
    """
    span = truth_span(az_truth, width_deg)
    if span is None:
        return
    start, extent = span
    off = np.mod(az_beams - support_deg - start, 360.0)
    bad = off + 2 * support_deg > extent + 1e-6
    if bad.any():
        b = float(az_beams[np.flatnonzero(bad)[0]])
        inside = np.mod(az_beams - start, 360.0)
        fits = float(np.min(np.minimum(inside, extent - inside)))
        hint = (
            f"; a pattern support of {np.floor(fits * 10) / 10:g} deg would fit every beam (the "
            "antenna's support_deg)"
            if fits >= 0.5 and np.all(inside <= extent)
            else "; move the beams inside it"
        )
        raise ValueError(
            f"the truth covers azimuth {start % 360:.1f} to {(start + extent) % 360:.1f} deg, but "
            f"the beam at {b:.1f} deg has a pattern support of +-{support_deg:g} deg; widen the "
            "truth's margin_deg where the file covers more (or read the whole sweep)" + hint
        )
