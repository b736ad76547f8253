"""Truth in three dimensions: the sweeps of a volume on one polar grid, where their gates are
in height, and what the truth is at any elevation between them.

A volume truth holds, beside the reference sweep's ``(radial, gate)`` moments, every sweep read
as ``volume_<moment>`` on ``(sweep, radial, gate)``: each sweep put on the reference sweep's
radials (the nearest radial of that sweep, within half its radial spacing) and gates (the gate
whose extent holds the centre), with its elevation ``sweep_elevation`` and its gates' heights
``height`` by the standard 4/3-earth propagation (Doviak and Zrnic 1993, eq. 2.28b):

    h = sqrt(r^2 + (k a)^2 + 2 r k a sin(el)) - k a,    k = 4/3, a = 6371 km.

Between sweeps the truth is interpolated in elevation (:func:`elevation_weights`): ``nearest``
takes the nearest sweep, ``linear`` mixes the two either side with weights linear in
elevation. The mixture acts on the echo, not on the dB values: the scatterers of both sweeps
with their powers weighted (:func:`mixture` gives the moments an ideal narrow beam then
measures), which is what the weather channel draws. Each sweep stands for the elevations
within half its beamwidth (``sweep_beamwidth_deg``); below the lowest sweep's and above the
top sweep's, nothing is invented: no echo.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph.fm301 import MOMENT_UNITS

from ..angles import circular_difference, nearest_radial

#: Effective earth radius factor of the standard atmosphere, and the earth's mean radius (m).
K_EARTH = 4.0 / 3.0
EARTH_RADIUS_M = 6_371_000.0
INTERPOLATIONS = ("linear", "nearest")
#: Moments used where a sweep has echo but not that moment (as the weather channel fills them).
_FILL = {"VRADH": 0.0, "WRADH": 1.0, "ZDR": 0.0, "RHOHV": 0.99, "PHIDP": 0.0}


def beam_height(range_m: Any, elevation_deg: Any) -> np.ndarray:
    """Height (m) of the beam centre above the radar, 4/3-earth propagation."""
    ka = K_EARTH * EARTH_RADIUS_M
    r = np.asarray(range_m, np.float64)
    s = np.sin(np.deg2rad(np.asarray(elevation_deg, np.float64)))
    return np.sqrt(r * r + ka * ka + 2.0 * r * ka * s) - ka


def ground_range(range_m: Any, elevation_deg: Any) -> np.ndarray:
    """Distance (m) along the earth's surface from the radar to below the beam centre."""
    ka = K_EARTH * EARTH_RADIUS_M
    r = np.asarray(range_m, np.float64)
    h = beam_height(r, elevation_deg)
    c = np.cos(np.deg2rad(np.asarray(elevation_deg, np.float64)))
    return ka * np.arcsin(r * c / (ka + h))


def covered(sweep_deg: np.ndarray, beamwidth_deg: float) -> tuple[float, float]:
    """The elevations a volume's sweeps stand for: half a beamwidth beyond the outer ones."""
    return float(sweep_deg.min() - beamwidth_deg / 2), float(sweep_deg.max() + beamwidth_deg / 2)


def elevation_weights(
    sweep_deg: np.ndarray, elevation_deg: Any, method: str, beamwidth_deg: float
) -> np.ndarray:
    """Weights (sweep x elevation) of each sweep in the truth at each elevation.

    ``sweep_deg`` ascending. Inside the sweeps' span: ``nearest`` gives the nearest sweep
    weight 1, ``linear`` the two either side 1 - t and t. Within half a beamwidth outside the
    span the outer sweep has weight 1; beyond, every weight is 0 (no echo).
    """
    el = np.atleast_1d(np.asarray(elevation_deg, np.float64))
    s = np.asarray(sweep_deg, np.float64)
    w = np.zeros((s.size, el.size))
    lo, hi = covered(s, beamwidth_deg)
    inside = np.flatnonzero((el >= lo) & (el <= hi))
    e = np.clip(el[inside], s[0], s[-1])
    if s.size == 1:
        w[0, inside] = 1.0
        return w
    if method == "nearest":
        w[np.argmin(np.abs(e[None, :] - s[:, None]), axis=0), inside] = 1.0
        return w
    k = np.clip(np.searchsorted(s, e, side="right") - 1, 0, s.size - 2)
    t = (e - s[k]) / (s[k + 1] - s[k])
    w[k, inside] = 1.0 - t
    w[k + 1, inside] += t
    return w


def select_angles(
    angles: Sequence[float], low_deg: float | None, high_deg: float | None
) -> list[float]:
    """The fixed angles inside [low, high] and the nearest one outside on each side (the
    interpolation's neighbours); all of them when the range is not given."""
    a = sorted(float(x) for x in angles)
    if low_deg is None or high_deg is None:
        return a
    first = max(0, int(np.searchsorted(a, low_deg, side="right")) - 1)
    last = min(len(a), int(np.searchsorted(a, high_deg, side="left")) + 1)
    return a[first:last]


def stack(sweeps: Sequence[Any], reference: Any) -> dict[str, np.ndarray]:
    """The sweeps' moments on the reference sweep's radials and gates: name -> (sweep,
    radial, gate) float32, NaN where a sweep has no radial within half its spacing or no gate
    (or not that moment)."""
    az_ref, rng_ref = reference.azimuth_deg, reference.range_m
    out = {
        name: np.full((len(sweeps), az_ref.size, rng_ref.size), np.nan, np.float32)
        for name in reference.fields
    }
    for k, sweep in enumerate(sweeps):
        rows = nearest_radial(az_ref, sweep.azimuth_deg)
        gap = np.abs(circular_difference(sweep.azimuth_deg[rows], az_ref, 360.0))
        ok_rows = gap <= 0.5 * max(sweep.radial_width_deg, reference.radial_width_deg) + 1e-6
        step = sweep.gate_width_m if np.isfinite(sweep.gate_width_m) else 1.0
        cols = np.floor((rng_ref - sweep.range_m[0]) / step + 0.5).astype(np.intp)
        ok_cols = (cols >= 0) & (cols < sweep.range_m.size)
        for name in out:
            if name in sweep.fields:
                values = sweep.fields[name][rows[ok_rows]][:, cols[ok_cols]]
                out[name][k][np.ix_(ok_rows, ok_cols)] = values
    return out


def volume_variables(
    sweeps: Sequence[Any], reference: Any, method: str, beamwidth_deg: float
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The truth Dataset's volume variables and attributes (see the module's description)."""
    order = np.argsort([s.elevation_deg for s in sweeps], kind="stable")
    kept: list[Any] = []
    for i in order:
        # Two sweeps at one elevation (a file that revisits it): the first one read.
        if not kept or sweeps[i].elevation_deg - kept[-1].elevation_deg > 0.01:
            kept.append(sweeps[i])
    sweeps = kept
    elevation = np.array([s.elevation_deg for s in sweeps], np.float64)
    fields = stack(sweeps, reference)
    variables: dict[str, Any] = {
        f"volume_{name}": (("sweep", "radial", "gate"), v, {"units": MOMENT_UNITS[name]})
        for name, v in fields.items()
    }
    variables["sweep_elevation"] = (
        "sweep",
        elevation,
        {"units": "degrees", "long_name": "mean measured elevation of each truth sweep"},
    )
    variables["height"] = (
        ("sweep", "gate"),
        beam_height(reference.range_m[None, :], elevation[:, None]),
        {"units": "meters", "long_name": "beam-centre height above the radar (4/3 earth)"},
    )
    attrs = {"elevation_interpolation": method, "sweep_beamwidth_deg": float(beamwidth_deg)}
    return variables, attrs


def mixture(fields: dict[str, np.ndarray], weight: np.ndarray) -> dict[str, np.ndarray]:
    """Moments an ideal narrow beam measures from sweeps mixed with ``weight`` (sweep x ...,
    broadcast against the fields' sweep x ... x gate): powers add, ZDR from the H and V
    powers, RHOHV and PHIDP from the summed H-V correlation, velocity and width from the
    summed spectrum's first two moments. One sweep with weight 1 gives its own moments."""
    w = weight[..., None]
    dbz = fields["DBZH"].astype(np.float64)
    echo = np.isfinite(dbz)
    zh = np.where(echo, 10 ** (np.nan_to_num(dbz) / 10), 0.0)
    total = (w * zh).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = {"DBZH": np.where(total > 0, 10 * np.log10(total), np.nan)}

        def filled(name: str) -> tuple[np.ndarray, np.ndarray]:
            v = fields[name].astype(np.float64)
            return np.where(np.isfinite(v), v, _FILL[name]), (w * np.isfinite(v)).sum(axis=0) > 0

        if "ZDR" in fields:
            zdr, has = filled("ZDR")
            zv = zh / 10 ** (zdr / 10)
            zv_total = (w * zv).sum(axis=0)
            out["ZDR"] = np.where(has & (total > 0), 10 * np.log10(total / zv_total), np.nan)
            if "RHOHV" in fields and "PHIDP" in fields:
                rho, has_r = filled("RHOHV")
                phi, has_p = filled("PHIDP")
                cross = (w * np.sqrt(zh * zv) * rho * np.exp(1j * np.deg2rad(phi))).sum(axis=0)
                norm = np.sqrt(total * zv_total)
                out["RHOHV"] = np.where(has_r & (total > 0), np.abs(cross) / norm, np.nan)
                out["PHIDP"] = np.where(
                    has_p & (total > 0), np.mod(np.rad2deg(np.angle(cross)), 360.0), np.nan
                )
        if "VRADH" in fields:
            v, has_v = filled("VRADH")
            mean = (w * zh * v).sum(axis=0) / total
            out["VRADH"] = np.where(has_v & (total > 0), mean, np.nan)
            if "WRADH" in fields:
                sw, has_w = filled("WRADH")
                second = (w * zh * (sw * sw + v * v)).sum(axis=0) / total
                out["WRADH"] = np.where(
                    has_w & (total > 0), np.sqrt(np.clip(second - mean * mean, 0, None)), np.nan
                )
    return {k: v.astype(np.float32) for k, v in out.items()}


def is_volume(truth: xr.Dataset) -> bool:
    """True when the truth holds a volume (``sweep_elevation`` and ``volume_*``)."""
    return "sweep_elevation" in truth.variables


def volume_fields(truth: xr.Dataset) -> dict[str, np.ndarray]:
    """The volume's moments: name -> (sweep, radial, gate) (not its wind, if it carries one)."""
    return {
        str(n).removeprefix("volume_"): truth[n].values
        for n in truth.data_vars
        if str(n).removeprefix("volume_") in MOMENT_UNITS and str(n).startswith("volume_")
    }


def beam_truth(truth: xr.Dataset, azimuth_deg: Any, elevation_deg: Any) -> xr.Dataset:
    """The truth each beam is centred on: moments on (beam, gate) at the radial nearest each
    beam's azimuth and, for a volume, at its elevation (interpolated between the sweeps as the
    truth says; NaN outside the volume). A single-sweep truth gives its radial as it is."""
    az = np.atleast_1d(np.asarray(azimuth_deg, np.float64))
    rows = nearest_radial(az, truth["azimuth"].values)
    if not is_volume(truth):
        fields = {str(n): truth[n].values[rows] for n in truth.data_vars if n in MOMENT_UNITS}
    else:
        w = elevation_weights(
            truth["sweep_elevation"].values,
            np.broadcast_to(np.asarray(elevation_deg, np.float64), az.shape),
            str(truth.attrs.get("elevation_interpolation", "linear")),
            float(truth.attrs.get("sweep_beamwidth_deg", 1.0)),
        )
        fields = mixture({k: v[:, rows] for k, v in volume_fields(truth).items()}, w)
    return xr.Dataset(
        {k: (("beam", "gate"), v, {"units": MOMENT_UNITS[k]}) for k, v in fields.items()},
        coords={"range": ("gate", truth["range"].values, {"units": "meters"})},
    )


def sweeps_read(truth: xr.Dataset, elevation_deg: Any) -> np.ndarray:
    """For each elevation, the index of the truth sweep with the largest weight there (-1:
    outside the volume); for a single-sweep truth, 0."""
    el = np.atleast_1d(np.asarray(elevation_deg, np.float64))
    if not is_volume(truth):
        return np.zeros(el.size, np.intp)
    w = elevation_weights(
        truth["sweep_elevation"].values,
        el,
        str(truth.attrs.get("elevation_interpolation", "linear")),
        float(truth.attrs.get("sweep_beamwidth_deg", 1.0)),
    )
    return np.where(w.max(axis=0) > 0, np.argmax(w, axis=0), -1)
