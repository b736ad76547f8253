"""Put the decoded cuts of one elevation on one polar grid: merge the surveillance and Doppler
cuts by azimuth and by range, cut the sector, and clean values outside their physical range.
"""

from __future__ import annotations

import numpy as np

from .level2 import DOPPLER_FIELDS, SURVEILLANCE_FIELDS, CutData, Moment

# Physical limits beyond which a decoded value is garbage rather than a measurement.
_DBZH_LIMITS = (-35.0, 100.0)
_ZDR_LIMITS = (-8.0, 8.0)
_RHOHV_LIMITS = (0.0, 1.1)  # open below, closed above: rho > 1 is a real estimate


# ---------------------------------------------------------------------- data assembly


def assemble(
    surveillance: CutData,
    doppler: CutData | None,
    *,
    radial_width_deg: float,
    sector_deg: tuple[float, float] | None,
    margin_deg: float,
    nyquist_velocity_ms: float = float("nan"),
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Merge the surveillance and Doppler cuts into cleaned, sector-cut fields.

    Radials come in time order. Only the surveillance radials in the sector, and the
    Doppler radials paired with them, are read.
    """
    azimuth = wrap360(surveillance.azimuth_deg.astype(np.float64))
    keep = drop_duplicate_radials(azimuth, radial_width_deg)
    order = keep[sector_order(azimuth[keep], sector_deg, margin_deg)]
    azimuth = azimuth[order]

    own_names = SURVEILLANCE_FIELDS + (DOPPLER_FIELDS if doppler is None else ())
    own = surveillance.read(order, own_names)
    if "DBZH" not in own:
        raise ValueError("the surveillance cut has no reflectivity")
    grid = own["DBZH"]
    range_m = grid.first_gate_m + grid.gate_step_m * np.arange(grid.codes.shape[1])

    fields: dict[str, np.ndarray] = {}
    for name in SURVEILLANCE_FIELDS:
        if name in own:
            fields[name] = _on_grid(own[name], range_m, grid.gate_step_m)
    if doppler is None:
        # A cut that measured everything at once: its own radials, its own gates.
        fields.update(_doppler_on_grid(own, range_m, grid.gate_step_m, nyquist_velocity_ms))
    else:
        src_az = wrap360(doppler.azimuth_deg.astype(np.float64))
        rows = _nearest_circular(azimuth, src_az, 0.5 * radial_width_deg)
        paired = rows >= 0
        needed = np.unique(rows[paired])
        moments = doppler.read(needed, DOPPLER_FIELDS)
        on_grid = _doppler_on_grid(moments, range_m, grid.gate_step_m, nyquist_velocity_ms)
        position = np.searchsorted(needed, rows[paired])
        for name, values in on_grid.items():
            out = np.full((azimuth.size, range_m.size), np.nan, dtype=np.float32)
            out[paired] = values[position]
            fields[name] = out
    return azimuth, range_m, clean_fields(fields)


def _cover_index(
    range_m: np.ndarray, first_gate_m: float, gate_step_m: float, n: int
) -> np.ndarray:
    """For each grid range, the source gate whose extent contains it, or -1."""
    k = np.floor((range_m - first_gate_m) / gate_step_m + 0.5).astype(np.intp)
    return np.where((k >= 0) & (k < n), k, -1)


def _on_grid(moment: Moment, range_m: np.ndarray, grid_step_m: float) -> np.ndarray:
    """A moment's values on the grid gates: the source gate that covers each gate centre.

    On the same gates (every message 31 surveillance moment) this is the identity, NaN
    beyond the moment's last gate.
    """
    values = moment.decode()
    cols = _cover_index(range_m, moment.first_gate_m, moment.gate_step_m, values.shape[1])
    out = np.full((values.shape[0], range_m.size), np.nan, dtype=np.float32)
    out[:, cols >= 0] = values[:, cols[cols >= 0]]
    return out


def _doppler_on_grid(
    moments: dict[str, Moment], range_m: np.ndarray, grid_step_m: float, nyquist_ms: float
) -> dict[str, np.ndarray]:
    """VRADH and WRADH (those present) on the grid gates, by range.

    Doppler gates as large as the grid gates or larger: each grid gate takes the Doppler gate
    that covers its centre (message 31: the same 250 m gates, so the identity).

    Finer Doppler gates (message 1: four 250 m velocity gates, centred -375, -125, 125 and
    375 m about each 1 km reflectivity gate): a grid gate stands for the whole 1 km volume,
    so it takes the mean over the Doppler gates whose centres lie inside it rather than one
    of them (the nearest would be a tie at the gate centre, and would throw away three
    quarters of the measurements). The velocity is a circular mean on the Nyquist interval,
    so gates folded at +-v_N average to the unfolded direction instead of to zero, and stays
    within the Nyquist interval like a measured one. The width is that of the sum of the
    sub-gate spectra (equal weights, for want of sub-gate reflectivity): the square root of
    the mean of w^2 plus the velocity spread about the mean. Gates with no valid sub-gate
    stay NaN.
    """
    out: dict[str, np.ndarray] = {}
    vel, width = moments.get("VRADH"), moments.get("WRADH")
    mean = None  # float64 mean velocity per grid gate, when averaged from finer gates
    for name, m in (("VRADH", vel), ("WRADH", width)):
        if m is not None and m.gate_step_m >= grid_step_m:
            out[name] = _on_grid(m, range_m, grid_step_m)
    if vel is not None and "VRADH" not in out:
        v, lo, hi, owner = _segments(vel, range_m, grid_step_m)
        out["VRADH"], mean = _velocity_mean(v, lo, hi, owner, nyquist_ms)
    if width is not None and "WRADH" not in out:
        w, lo, hi, owner = _segments(width, range_m, grid_step_m)
        spread_sq = np.zeros_like(w, dtype=np.float64)
        same_gates = vel is not None and (vel.first_gate_m, vel.gate_step_m) == (
            width.first_gate_m,
            width.gate_step_m,
        )
        if same_gates and mean is not None and vel is not None:
            v = vel.decode().astype(np.float64)
            inside = owner >= 0
            d = np.zeros_like(v)
            d[:, inside] = _velocity_difference(v[:, inside], mean[:, owner[inside]], nyquist_ms)
            spread_sq = np.where(np.isfinite(d), d * d, 0.0)
        w64 = w.astype(np.float64)
        ok = np.isfinite(w64)
        total = _segment_sum(np.where(ok, w64 * w64 + spread_sq, 0.0), lo, hi)
        count = _segment_sum(ok.astype(np.float64), lo, hi)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["WRADH"] = np.sqrt(total / count).astype(np.float32)
    return out


def _segments(
    moment: Moment, range_m: np.ndarray, grid_step_m: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Decoded values and, per grid gate, the run [lo, hi) of source gates inside it.

    Also returns the owning grid gate of each source gate (-1 outside the grid).
    """
    values = moment.decode()
    src = moment.first_gate_m + moment.gate_step_m * np.arange(values.shape[1])
    edges = np.append(range_m - 0.5 * grid_step_m, range_m[-1] + 0.5 * grid_step_m)
    bounds = np.searchsorted(src, edges, side="left")
    owner = np.searchsorted(edges, src, side="right") - 1
    owner[(owner < 0) | (owner >= range_m.size)] = -1
    return values, bounds[:-1], bounds[1:], owner


def _segment_sum(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of x[:, lo[k]:hi[k]] for every k (0 for an empty run)."""
    return _segment_reduce(np.add, x, lo, hi, 0.0)


def _segment_reduce(
    op: np.ufunc, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, empty: float
) -> np.ndarray:
    """``op`` reduced over x[:, lo[k]:hi[k]] for every k; the runs are adjacent and in order."""
    out = np.full((x.shape[0], lo.size), empty, dtype=np.float64)
    full = hi > lo
    if full.any():
        out[:, full] = op.reduceat(x[:, : hi[full][-1]], lo[full], axis=1)
    return out


def _velocity_mean(
    v: np.ndarray, lo: np.ndarray, hi: np.ndarray, owner: np.ndarray, nyquist_ms: float
) -> tuple[np.ndarray, np.ndarray]:
    """Mean velocity over each run of gates (circular on +-nyquist_ms when it is known).

    The mean is taken of the differences from one valid velocity of the run (the largest),
    folded into the Nyquist interval, and added back to it: one valid gate, or several
    equal ones, give exactly their value, and a value just beyond the Nyquist velocity (the
    0.5 m/s code steps allow it) is not flipped to the other end of the interval. The sum
    is folded back into the Nyquist interval (widened to the reference value).
    Returns the float32 mean and the float64 one (for the width's velocity spread).
    """
    v64 = v.astype(np.float64)
    ok = np.isfinite(v64)
    count = _segment_sum(ok.astype(np.float64), lo, hi)
    ref = _segment_reduce(np.fmax, v64, lo, hi, np.nan)
    inside = owner >= 0
    d = np.zeros_like(v64)
    d[:, inside] = _velocity_difference(v64[:, inside], ref[:, owner[inside]], nyquist_ms)
    d[~ok] = 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        if np.isfinite(nyquist_ms) and nyquist_ms > 0:
            phase = d * (np.pi / nyquist_ms)
            c = _segment_sum(np.where(ok, np.cos(phase), 0.0), lo, hi)
            s = _segment_sum(np.where(ok, np.sin(phase), 0.0), lo, hi)
            mean = ref + np.arctan2(s, c) * (nyquist_ms / np.pi)
            # Back into the Nyquist interval, which reaches as far as the reference does.
            mean = np.where(mean > np.maximum(ref, nyquist_ms), mean - 2 * nyquist_ms, mean)
            mean = np.where(mean < np.minimum(ref, -nyquist_ms), mean + 2 * nyquist_ms, mean)
        else:
            mean = ref + _segment_sum(d, lo, hi) / count
    mean = np.where(count > 0, mean, np.nan)
    return mean.astype(np.float32), mean


def _velocity_difference(a: np.ndarray, b: np.ndarray, nyquist_ms: float) -> np.ndarray:
    """a - b, folded into [-v_N, v_N) when the Nyquist velocity is known."""
    d = a - b
    if np.isfinite(nyquist_ms) and nyquist_ms > 0:
        d = np.mod(d + nyquist_ms, 2.0 * nyquist_ms) - nyquist_ms
    return d


def clean_fields(fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Replace physically impossible values by NaN and wrap PHIDP into [0, 360)."""
    out: dict[str, np.ndarray] = {}
    for name, values in fields.items():
        v = values.astype(np.float32, copy=True)
        if name == "DBZH":
            v[~((v >= _DBZH_LIMITS[0]) & (v <= _DBZH_LIMITS[1]))] = np.nan
        elif name == "ZDR":
            v[~((v >= _ZDR_LIMITS[0]) & (v <= _ZDR_LIMITS[1]))] = np.nan
        elif name == "RHOHV":
            v[~((v > _RHOHV_LIMITS[0]) & (v <= _RHOHV_LIMITS[1]))] = np.nan
        elif name == "PHIDP":
            v[~np.isfinite(v)] = np.nan
            v = wrap360(v)
        elif name == "WRADH":
            # Width shares velocity's code table, so codes below 129 decode to negatives.
            v[~(v >= 0.0)] = np.nan
        else:
            v[~np.isfinite(v)] = np.nan
        out[name] = v
    if "DBZH" in out:
        # Without an echo there is nothing the other moments could have measured.
        no_echo = np.isnan(out["DBZH"])
        for name, v in out.items():
            if name != "DBZH":
                v[no_echo] = np.nan
    return out


# ------------------------------------------------------------------ geometry helpers


def wrap360(angle: np.ndarray) -> np.ndarray:
    """Wrap angles into [0, 360) in their own dtype (NaN stays NaN); returns a new array."""
    wrapped = np.array(angle, copy=True)
    # Only the angles outside the turn: np.mod is slow on the NaN of a masked field, and
    # leaves an angle already in [0, 360) unchanged anyway.
    outside = (wrapped < 0.0) | (wrapped >= 360.0)
    folded = np.mod(wrapped[outside], wrapped.dtype.type(360.0))
    # mod of a tiny negative number rounds to exactly 360 in floating point.
    folded[folded >= 360.0] = 0.0
    wrapped[outside] = folded
    return wrapped


def check_sector(
    sector_deg: tuple[float, float] | None, margin_deg: float
) -> tuple[tuple[float, float] | None, float]:
    """Validate the sector arguments early, before any file is read."""
    margin = float(margin_deg)
    if not np.isfinite(margin) or margin < 0:
        raise ValueError(f"margin_deg must be a finite, non-negative angle, got {margin_deg}")
    if sector_deg is None:
        return None, margin
    if len(sector_deg) != 2:
        raise ValueError(f"sector_deg must be (az0, az1), got {sector_deg!r}")
    az0, az1 = (float(a) for a in sector_deg)
    if not (np.isfinite(az0) and np.isfinite(az1)):
        raise ValueError(f"sector_deg must be finite angles, got {sector_deg!r}")
    return (az0, az1), margin


def sector_order(
    azimuth: np.ndarray, sector_deg: tuple[float, float] | None, margin_deg: float
) -> np.ndarray:
    """Indices of the radials inside the sector, in clockwise order from its start."""
    if sector_deg is None:
        start, span = 0.0, 360.0
    else:
        az0, az1 = sector_deg
        if az1 - az0 >= 360.0:
            start, span = az0, 360.0
        else:
            span = (az1 - az0) % 360.0 + 2.0 * margin_deg
            start = az0 - margin_deg if span < 360.0 else az0
    offset = np.mod(azimuth - start, 360.0)
    # Tolerance for sector edges given as decimal angles that are not exact binary floats.
    inside = np.flatnonzero(offset <= span + 1e-9) if span < 360.0 else np.arange(azimuth.size)
    return inside[np.argsort(offset[inside], kind="stable")]


def drop_duplicate_radials(azimuth: np.ndarray, radial_width_deg: float) -> np.ndarray:
    """Indices of radials to keep when a sweep overlaps itself (e.g. 721 radials).

    Of two radials closer than half a radial spacing, the later one (higher index, as rows
    come in time order) is dropped, so the truth grid never holds a radial twice.
    """
    n = azimuth.size
    if n < 2 or not np.isfinite(radial_width_deg):
        return np.arange(n)
    by_az = np.argsort(azimuth, kind="stable")
    gap = np.mod(np.diff(azimuth[np.append(by_az, by_az[0])]), 360.0)
    close = np.flatnonzero(gap < 0.5 * radial_width_deg)
    if close.size == 0:
        return np.arange(n)
    pairs = np.stack([by_az[close], by_az[(close + 1) % n]])
    keep = np.ones(n, dtype=bool)
    keep[pairs.max(axis=0)] = False
    return np.flatnonzero(keep)


def _nearest_circular(target: np.ndarray, source: np.ndarray, tolerance: float) -> np.ndarray:
    """For each target azimuth, the index of the nearest source azimuth, or -1 if too far.

    Of source radials at exactly the same azimuth (a sweep that overlaps itself) the one
    with the lowest index, i.e. the earlier in time, is taken.
    """
    if source.size == 0:
        return np.full(target.size, -1, dtype=np.intp)
    order = np.argsort(source, kind="stable")
    ring = source[order]
    # Pad the sorted ring with its neighbours across north so the search never falls off.
    padded = np.concatenate([ring[-1:] - 360.0, ring, ring[:1] + 360.0])
    pos = np.clip(np.searchsorted(padded, target), 1, padded.size - 1)
    left, right = padded[pos - 1], padded[pos]
    pick = np.where(target - left <= right - target, pos - 1, pos)
    # First of a run of equal azimuths: the stable sort put the earliest radial there.
    pick = np.searchsorted(padded, padded[pick], side="left")
    dist = np.abs(padded[pick] - target)
    index = order[(pick - 1) % ring.size]
    return np.where(dist <= tolerance, index, -1)


def nominal_spacing(azimuth: np.ndarray) -> float:
    """Nominal radial spacing when the headers do not give it: 0.5 or 1 deg if close."""
    if azimuth.size < 2:
        return float("nan")
    ring = np.sort(wrap360(azimuth.astype(np.float64)))
    median = float(np.median(np.diff(ring)))
    for nominal in (0.5, 1.0):
        if abs(median - nominal) <= 0.1 * nominal:
            return nominal
    return median


def gate_width(range_m: np.ndarray) -> float:
    """Gate spacing, robust to float32 rounding of the range coordinate."""
    if range_m.size < 2:
        return float("nan")
    return float(np.round(np.median(np.diff(range_m)), 3))
