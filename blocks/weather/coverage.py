"""What a beam may ask of a truth read for a sector only: its pattern must stay inside it."""

from __future__ import annotations

import numpy as np


def check_coverage(
    az_truth: np.ndarray, width_deg: float, az_beams: np.ndarray, support_deg: float
) -> None:
    """Refuse beams whose pattern reaches beyond a truth read for a sector only.

    A truth read for a sector (``truth.azimuth_start_deg``) ends somewhere; a beam whose
    pattern grid reaches past that end would silently miss the echo there.
    """
    az = np.sort(np.mod(az_truth, 360.0))
    if az.size < 2:
        return
    gaps = np.diff(np.concatenate([az, [az[0] + 360.0]]))
    k = int(np.argmax(gaps))
    if gaps[k] <= 2.5 * width_deg:
        return  # the whole circle
    start = az[(k + 1) % az.size] - width_deg / 2
    extent = 360.0 - gaps[k] + width_deg
    off = np.mod(az_beams - support_deg - start, 360.0)
    bad = off + 2 * support_deg > extent + 1e-6
    if bad.any():
        b = float(az_beams[np.flatnonzero(bad)[0]])
        raise ValueError(
            f"the truth covers azimuth {start % 360:.1f} to {(start + extent) % 360:.1f} deg, but "
            f"the beam at {b:.1f} deg has a pattern support of +-{support_deg:g} deg; widen the "
            "truth's margin_deg (or read the whole sweep)"
        )
