"""Truth for a radar that stands somewhere else than the radar whose volume is the truth: every
gate of virtual sweeps from the new site placed in three dimensions (:mod:`.sites`), and the
truth volume read there, from its own origin, as the weather channel reads it
(:mod:`.volume`: the nearest radial and gate of each sweep, mixed in elevation)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param, RunNote

from ..angles import circular_difference
from ..signals import TRUTH
from .gridding import clean_fields, sector_order
from .nexrad import truth_dataset
from .nexrad_io import TruthSweep
from .sites import offset_site, project_wind, seen_from
from .volume import (
    INTERPOLATIONS,
    elevation_weights,
    is_volume,
    mixture,
    select_angles,
    volume_fields,
    volume_variables,
)

#: The truth's wind, when it carries one (truth.grid from u, v, w): east, north, up (m/s).
WIND = ("volume_eastward_wind", "volume_northward_wind", "volume_upward_wind")
#: What a single radar's velocity cannot be, said once where it is refused or left out.
WHY = (
    "the radial velocity of a single radar's volume is the wind along that radar's own beams "
    "and cannot be projected onto another radar's beams"
)


def has_wind(truth: xr.Dataset) -> bool:
    return all(k in truth for k in WIND)


def nearest_sorted(
    azimuth_deg: np.ndarray, radials_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Index of the radial nearest each azimuth and the gap to it (deg), for many azimuths:
    by binary search on the radials sorted on the circle (``nearest_radial`` without its
    azimuths x radials matrix)."""
    order = np.argsort(radials_deg % 360.0)
    ring = radials_deg[order] % 360.0
    a = np.asarray(azimuth_deg, np.float64) % 360.0
    k = np.searchsorted(ring, a)
    lo, hi = order[(k - 1) % ring.size], order[k % ring.size]
    d_lo = np.abs(circular_difference(radials_deg[lo], a, 360.0))
    d_hi = np.abs(circular_difference(radials_deg[hi], a, 360.0))
    near = np.where(d_lo <= d_hi, lo, hi)
    return near, np.minimum(d_lo, d_hi)


def read_volume(
    truth: xr.Dataset, range_m: np.ndarray, azimuth_deg: np.ndarray, elevation_deg: np.ndarray
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The truth volume's moments at points given from its own site (any shape): the nearest
    radial (within half the radial spacing) and gate (whose extent holds the point) of every
    sweep, mixed over elevation as the truth says (:func:`.volume.mixture`); NaN outside.
    Also the elevation weights (sweep x point), for the wind."""
    shape = np.shape(range_m)
    az = truth["azimuth"].values
    rng = truth["range"].values
    gate = float(truth.attrs["gate_width_m"])
    width = float(truth.attrs["radial_width_deg"])
    rows, gap = nearest_sorted(np.ravel(azimuth_deg), az)
    cols = np.floor((np.ravel(range_m) - rng[0]) / gate + 0.5).astype(np.intp)
    inside = (gap <= width / 2 + 1e-6) & (cols >= 0) & (cols < rng.size)
    rows, cols = np.where(inside, rows, 0), np.clip(cols, 0, rng.size - 1)
    w = elevation_weights(
        truth["sweep_elevation"].values,
        np.ravel(elevation_deg),
        str(truth.attrs.get("elevation_interpolation", "linear")),
        float(truth.attrs.get("sweep_beamwidth_deg", 1.0)),
    )
    w[:, ~inside] = 0.0
    volume = volume_fields(truth)
    # Only the points with echo in a sweep that weighs on them are mixed (the rest: NaN).
    echo = ((w > 0) & np.isfinite(volume["DBZH"][:, rows, cols])).any(axis=0)
    r, c, we = rows[echo], cols[echo], w[:, echo]
    mixed = mixture({k: v[:, r, c][..., None] for k, v in volume.items()}, we)
    out = {}
    for k, v in mixed.items():
        full = np.full(echo.size, np.nan, np.float32)
        full[echo] = v[:, 0]
        out[k] = full.reshape(shape)
    return out, w


class ElsewhereTruth(Block):
    """The truth as a radar at another site and height than the truth's radar sees it.

    The radar stands ``east_m`` east and ``north_m`` north of the truth's radar (along the
    ground), or at ``latitude``, ``longitude``, and ``altitude_m`` above the datum (unset:
    the truth radar's altitude). Virtual sweeps every ``elevation_step_deg`` from
    ``elevation_min_deg`` to ``elevation_max_deg``, widened by ``elevation_margin_deg``, on
    radials ``radial_width_deg`` apart and gates ``gate_width_m`` apart to ``max_range_m``,
    are placed in three dimensions from the new site (4/3 earth on a spherical earth,
    :mod:`pasim_blocks.truth.sites`) and the truth volume is read at each gate from its own
    site: the nearest radial and gate of each truth sweep, mixed in elevation as the truth
    says. Reflectivity, the polarimetric moments and the spectrum width move with the gates.
    The result is a volume truth from the new site (its latitude, longitude and altitude),
    which the scan, the weather channel and the scorer read as any other.

    Radial velocity: a truth that carries its wind (``truth.grid`` with u, v, w) gives the
    wind projected on each new ray at the gate (exact); a single radar's volume cannot be
    projected, so with ``velocity: refuse`` the run stops with one line saying why, and with
    ``velocity: omit`` the truth has no VRADH (the weather channel takes 0 m/s, velocity is
    not scored; the spectrum width still moves with the gates, but is not scored either,
    since the scorer's truth mixes widths with the velocities). The truth must be a volume
    (``truth.nexrad`` with ``sweeps: volume``, or ``truth.grid``).
    """

    truth_in = Input(TRUTH, doc="truth volume from its own radar's site")
    truth = Output(TRUTH, doc="truth volume from the new site")

    east_m = Param(0.0, units="m", min=-1e6, max=1e6, doc="new site east of the truth's radar")
    north_m = Param(0.0, units="m", min=-1e6, max=1e6, doc="new site north of the truth's radar")
    latitude = Param(
        None, units="deg", min=-90.0, max=90.0, optional=True, doc="new site latitude (or east_m)"
    )
    longitude = Param(
        None, units="deg", min=-180.0, max=360.0, optional=True, doc="new site longitude"
    )
    altitude_m = Param(
        None,
        units="m",
        min=-500.0,
        max=2e4,
        optional=True,
        doc="new radar's altitude above the datum (unset: the truth radar's)",
    )
    elevation_deg = Param(0.5, units="deg", min=-10.0, max=90.0, doc="reference sweep elevation")
    elevation_min_deg = Param(0.5, units="deg", min=-10.0, max=90.0, doc="lowest scan elevation")
    elevation_max_deg = Param(0.5, units="deg", min=-10.0, max=90.0, doc="highest scan elevation")
    elevation_step_deg = Param(
        0.25, units="deg", min=0.01, max=10.0, doc="spacing of the virtual sweeps"
    )
    elevation_margin_deg = Param(
        1.5, units="deg", min=0.0, max=45.0, doc="virtual sweeps beyond the scan's elevations"
    )
    elevation_interpolation = Param(
        "linear", type="str", choices=INTERPOLATIONS, doc="between virtual sweeps"
    )
    radial_width_deg = Param(0.5, units="deg", min=0.01, max=10.0, doc="radial spacing")
    gate_width_m = Param(250.0, units="m", min=1.0, max=10_000.0, doc="gate spacing")
    max_range_m = Param(150_000.0, units="m", min=1000.0, max=1e6, doc="range of the last gate")
    azimuth_start_deg = Param(
        None, units="deg", min=0.0, max=360.0, optional=True, doc="sample from this azimuth"
    )
    azimuth_stop_deg = Param(
        None, units="deg", min=0.0, max=360.0, optional=True, doc="sample up to this azimuth"
    )
    margin_deg = Param(10.0, units="deg", min=0.0, max=180.0, doc="radials beyond the sector")
    velocity = Param(
        "refuse",
        type="str",
        choices=("refuse", "omit"),
        doc="a truth without wind: refuse (its radial velocity cannot be projected) or omit "
        "(no VRADH); a truth with wind projects it",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        if (params.get("latitude") is None) != (params.get("longitude") is None):
            return [("parameter 'latitude'", "give both latitude and longitude (or east_m)")]
        low = params.get("elevation_min_deg", cls.params["elevation_min_deg"].default)
        high = params.get("elevation_max_deg", cls.params["elevation_max_deg"].default)
        if low > high:
            return [("parameter 'elevation_min_deg'", f"{low:g} is above elevation_max_deg")]
        return []

    def site(
        self, truth: xr.Dataset
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The new site and the truth's (latitude, longitude, altitude)."""
        a = truth.attrs
        other = (float(a["latitude"]), float(a["longitude"]), float(a["altitude"]))
        p = self.p
        if p["latitude"] is not None:
            lat, lon = float(p["latitude"]), float(p["longitude"])
        else:
            lat, lon = offset_site(other[0], other[1], p["east_m"], p["north_m"])
        alt = other[2] if p["altitude_m"] is None else float(p["altitude_m"])
        return (lat, lon, alt), other

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        truth = inputs["truth_in"]
        source = str(truth.attrs.get("source", "truth"))
        if not is_volume(truth):
            raise ValueError(
                f"truth {source}: the radar elsewhere needs a volume truth to place its gates "
                "in three dimensions (truth.nexrad with sweeps: volume, or truth.grid)"
            )
        wind = has_wind(truth)
        if "volume_VRADH" in truth and not wind:
            if self.p["velocity"] == "refuse":
                raise ValueError(
                    f"truth {source}: radial velocity refused: {WHY}; set velocity: omit "
                    "(no velocity) or use a truth.grid with u, v, w"
                )
            warnings.warn(
                f"truth {source}: no radial velocity from the new site: {WHY}",
                RunNote,
                2,
            )
        p = self.p
        site, other = self.site(truth)
        n_rad = max(1, round(360.0 / p["radial_width_deg"]))
        width = 360.0 / n_rad
        azimuth = (np.arange(n_rad) + 0.5) * width
        start, stop = p["azimuth_start_deg"], p["azimuth_stop_deg"]
        if start is not None and stop is not None and (stop - start) % 360.0:
            azimuth = azimuth[sector_order(azimuth, (start, stop), p["margin_deg"])]
        rng = p["gate_width_m"] * (np.arange(int(p["max_range_m"] // p["gate_width_m"])) + 0.5)
        step = p["elevation_step_deg"]
        lo = p["elevation_min_deg"] - p["elevation_margin_deg"]
        hi = p["elevation_max_deg"] + p["elevation_margin_deg"]
        elevations = select_angles(
            list(np.arange(np.floor(lo / step) - 1, np.ceil(hi / step) + 2) * step), lo, hi
        )
        sweeps, winds = [], []
        for e in elevations:
            seen = seen_from(site, other, rng, azimuth, float(e))
            fields, w = read_volume(truth, seen.range_m, seen.azimuth_deg, seen.elevation_deg)
            fields.pop("VRADH", None)
            if wind:
                total = np.maximum(w.sum(axis=0), 1e-300)
                east, north, up = (
                    np.nan_to_num(
                        np.einsum("sp,sp->p", w, self._at(truth[k].values, truth, seen)) / total
                    ).reshape(seen.range_m.shape)
                    for k in WIND
                )
                outside = (w.sum(axis=0) == 0).reshape(seen.range_m.shape)
                radial = project_wind(east, north, up, seen.ray_azimuth_deg, seen.ray_elevation_deg)
                fields["VRADH"] = np.where(outside, np.nan, radial).astype(np.float32)
                winds.append((east, north, up))
            sweeps.append(
                TruthSweep(
                    azimuth_deg=azimuth,
                    elevation_deg=float(e),
                    range_m=rng,
                    radial_width_deg=width,
                    gate_width_m=float(p["gate_width_m"]),
                    fields=clean_fields(fields),
                    nyquist_velocity_ms=float("nan"),
                    site={},
                    source=source,
                )
            )
        ref = int(np.argmin([abs(s.elevation_deg - p["elevation_deg"]) for s in sweeps]))
        variables, attrs = volume_variables(sweeps, sweeps[ref], p["elevation_interpolation"], step)
        if wind:
            for k, i in zip(WIND, range(3), strict=True):
                variables[k] = (
                    ("sweep", "radial", "gate"),
                    np.stack([wd[i] for wd in winds]).astype(np.float32),
                    dict(truth[k].attrs),
                )
        ds = truth_dataset(
            sweeps[ref].fields,
            azimuth,
            rng,
            elevation_deg=sweeps[ref].elevation_deg,
            radial_width_deg=width,
            gate_width_m=float(p["gate_width_m"]),
            nyquist_velocity_ms=float("nan"),
            polarimetric=int(sweeps[ref].polarimetric),
            source=f"{source} seen from {site[0]:.4f}, {site[1]:.4f}, {site[2]:g} m",
            time_coverage_start=str(truth.attrs.get("time_coverage_start", "2000-01-01T00:00:00Z")),
            latitude=site[0],
            longitude=site[1],
            altitude=site[2],
            instrument_name=str(truth.attrs.get("instrument_name", "synthetic")),
        )
        ds = ds.assign(variables)
        ds.attrs.update(attrs)
        return {"truth": ds}

    @staticmethod
    def _at(values: np.ndarray, truth: xr.Dataset, seen: Any) -> np.ndarray:
        """A (sweep, radial, gate) truth variable at the gates' nearest radial and gate
        (sweep x point), 0 outside."""
        rows, gap = nearest_sorted(np.ravel(seen.azimuth_deg), truth["azimuth"].values)
        rng = truth["range"].values
        cols = np.floor(
            (np.ravel(seen.range_m) - rng[0]) / float(truth.attrs["gate_width_m"]) + 0.5
        ).astype(np.intp)
        ok = (gap <= float(truth.attrs["radial_width_deg"]) / 2 + 1e-6) & (cols >= 0)
        ok &= cols < rng.size
        out = values[:, np.where(ok, rows, 0), np.clip(cols, 0, rng.size - 1)]
        return np.where(ok[None, :], np.nan_to_num(out), 0.0)
