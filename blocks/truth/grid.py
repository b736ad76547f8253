"""Truth from a gridded field: an xarray Dataset (a model's output, a composite) on Cartesian
``(z, y, x)`` or geographic ``(height, lat, lon)`` axes, seen by a radar placed anywhere inside
it, sampled onto virtual sweeps with the 4/3-earth propagation of :mod:`.volume`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param, RunNote
from pasim_graph.fm301 import MOMENT_FIELDS

from ..signals import TRUTH
from .gridding import clean_fields, sector_order
from .nexrad import truth_dataset
from .nexrad_io import TruthSweep
from .radar_files import damaged, field_map, mapping_hint, unknown_names
from .sites import destination, distance_bearing, project_wind
from .sizes import check_grid, check_zarr
from .volume import (
    EARTH_RADIUS_M,
    INTERPOLATIONS,
    K_EARTH,
    beam_height,
    ground_range,
    select_angles,
    volume_variables,
)

#: Names of the axes, in order of preference (matched without regard to case).
VERTICAL = ("z", "height", "altitude", "alt", "heightAboveSeaLevel")
CARTESIAN = (("y", "north", "y_m"), ("x", "east", "x_m"))
GEOGRAPHIC = (("lat", "latitude"), ("lon", "longitude"))
#: The wind's components (east, north, up; m/s), by name (any case); up may be absent (0).
WIND_NAMES = (
    ("u", "eastward_wind", "ua", "u_wind"),
    ("v", "northward_wind", "va", "v_wind"),
    ("w", "upward_air_velocity", "wa", "w_wind"),
)
WIND_KEYS = ("eastward", "northward", "upward")


class Grid:
    """A gridded field read and checked: its moments on (vertical, y or lat, x or lon) in
    metres or degrees, and which kind of axes it has."""

    def __init__(self, ds: xr.Dataset, source: str, fields: dict[str, str] | None = None):
        self.source = source
        problems: list[str] = []
        lower = {str(n).lower(): str(n) for n in ds.variables}
        z = next((lower[n.lower()] for n in VERTICAL if n.lower() in lower), None)
        horizontal = None
        for kind, candidates in (("cartesian", CARTESIAN), ("geographic", GEOGRAPHIC)):
            found = [
                next((lower[n.lower()] for n in names if n.lower() in lower), None)
                for names in candidates
            ]
            if all(found):
                horizontal = (kind, found)
                break
        if z is None or horizontal is None:
            problems.append(
                "no coordinates: needs a vertical axis (one of "
                + ", ".join(VERTICAL)
                + ") and x, y (metres) or lat, lon (degrees)"
            )
        names = [str(n) for n in ds.data_vars if ds[n].ndim == 3]
        wind = [next((lower[n] for n in alias if n in lower), None) for alias in WIND_NAMES]
        # With u and v the radial velocity is the wind on each ray (exact from any site).
        self.wind = [w for w in wind if w is not None] if wind[0] and wind[1] else []
        names = [n for n in names if n not in self.wind]
        standard = {n: str(ds[n].attrs.get("standard_name", "")) for n in names}
        self.mapping = field_map(names, standard, fields, f"gridded truth {source}")
        if self.wind:
            self.mapping.pop("VRADH", None)
            self.mapping.update({f"{k}_wind": w for k, w in zip(WIND_KEYS, wind, strict=True) if w})
        if "DBZH" not in self.mapping:
            unknown = unknown_names(names, self.mapping)
            problems.append(
                "no reflectivity field (DBZH, reflectivity, ... or a CF standard name); its "
                f"three-dimensional variables: {', '.join(names) or 'none'}"
                + (f" ({mapping_hint('DBZH', unknown)})" if unknown else "")
            )
        if problems:
            raise ValueError(f"gridded truth {source}: " + "; ".join(problems))
        assert z is not None and horizontal is not None
        self.kind, (ya, xa) = horizontal
        declared = [str(v) for v in (z, ya, xa, *self.mapping.values())]
        check_grid(
            f"gridded truth {source}",
            {v: (tuple(map(str, ds[v].dims)), tuple(ds[v].shape)) for v in declared},
        )
        axes = [
            _metres(ds[z]),
            _metres(ds[ya]) if self.kind == "cartesian" else ds[ya].values.astype(np.float64),
            _metres(ds[xa]) if self.kind == "cartesian" else ds[xa].values.astype(np.float64),
        ]
        dims = (ds[z].dims[0], ds[ya].dims[0], ds[xa].dims[0])
        self.fields: dict[str, np.ndarray] = {}
        for moment, var in self.mapping.items():
            da = ds[var]
            if set(da.dims) != set(dims):
                raise ValueError(
                    f"gridded truth {source}: {var} is on ({', '.join(map(str, da.dims))}), "
                    f"not on the axes ({', '.join(map(str, dims))})"
                )
            self.fields[moment] = da.transpose(*dims).values.astype(np.float32)
        for i, axis in enumerate(axes):
            if axis.size > 1 and np.all(np.diff(axis) < 0):  # descending (latitudes often)
                axes[i] = axis[::-1]
                self.fields = {k: np.flip(v, axis=i) for k, v in self.fields.items()}
            if axes[i].size < 2 or not np.all(np.diff(axes[i]) > 0):
                raise ValueError(
                    f"gridded truth {source}: axis {dims[i]} is not monotonic with at least "
                    "two points"
                )
        self.axes = tuple(axes)

    def inside(self, z: float, y: float, x: float) -> bool:
        return all(a[0] <= v <= a[-1] for a, v in zip(self.axes, (z, y, x), strict=True))

    def sample(self, z: np.ndarray, y: np.ndarray, x: np.ndarray) -> dict[str, np.ndarray]:
        """Trilinear interpolation of every moment at the points (NaN outside the grid)."""
        from scipy.interpolate import RegularGridInterpolator

        points = np.stack([z.ravel(), y.ravel(), x.ravel()], axis=-1)
        out = {}
        for name, values in self.fields.items():
            f = RegularGridInterpolator(self.axes, values, bounds_error=False, fill_value=np.nan)
            out[name] = f(points).reshape(z.shape).astype(np.float32)
        return out


def _metres(da: xr.DataArray) -> np.ndarray:
    values = np.asarray(da.values, np.float64)
    return values * 1000.0 if str(da.attrs.get("units", "m")).strip() == "km" else values


def open_grid(path: str | Path, fields: dict[str, str] | None = None) -> Grid:
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"gridded truth not found (no such file): {path}")
    if path.is_dir():
        check_zarr(path)
    try:
        ds = xr.open_zarr(path) if path.is_dir() else xr.open_dataset(path)
    except Exception as exc:
        raise ValueError(f"gridded truth {path}: not a netCDF file or Zarr store ({exc})") from None
    with damaged(f"gridded truth {path}", path.name):
        return Grid(ds, path.name, fields)


class GriddedTruth(Block):
    """Truth sampled from a gridded field by a radar placed inside it.

    The file (netCDF or Zarr, anything ``xarray`` opens) holds reflectivity and any of the
    other moments (named as in radar files: ``DBZH``, ``reflectivity``, ``ZDR``, ... or by CF
    standard name) on a vertical axis (``z``, ``height`` or ``altitude``, metres above the
    grid's datum; ``units: km`` is converted) and either Cartesian ``y``, ``x`` (metres) or
    geographic ``lat``, ``lon`` (degrees). The radar sits at ``x_m``, ``y_m`` (Cartesian) or
    ``latitude``, ``longitude`` (geographic), ``altitude_m`` above the datum. Virtual sweeps
    every ``elevation_step_deg`` between ``elevation_min_deg`` and ``elevation_max_deg``,
    widened by ``elevation_margin_deg`` (and one beyond each), are sampled at the centres of
    ``radial_width_deg`` x ``gate_width_m`` cells, each gate placed by 4/3-earth propagation,
    the moments trilinearly interpolated; the truth is a volume
    (:mod:`pasim_blocks.truth.volume`), interpolated between the virtual
    sweeps as ``elevation_interpolation`` says. Gates outside the grid have no echo. A file
    without reflectivity or without coordinates, or a radar outside the grid, is refused
    before anything is sampled.
    """

    role = "truth"

    truth = Output(TRUTH, doc="truth fields sampled from the grid, as a volume")

    path = Param("", type="path", doc="gridded field: netCDF file or Zarr store")
    x_m = Param(None, units="m", min=-1e7, max=1e7, optional=True, doc="radar's x (Cartesian)")
    y_m = Param(None, units="m", min=-1e7, max=1e7, optional=True, doc="radar's y (Cartesian)")
    latitude = Param(None, units="deg", min=-90.0, max=90.0, optional=True, doc="radar latitude")
    longitude = Param(
        None, units="deg", min=-180.0, max=360.0, optional=True, doc="radar longitude"
    )
    altitude_m = Param(0.0, units="m", min=-500.0, max=1e4, doc="radar height above the datum")
    elevation_deg = Param(0.5, units="deg", min=-2.0, max=90.0, doc="reference sweep elevation")
    elevation_min_deg = Param(0.0, units="deg", min=-2.0, max=90.0, doc="lowest virtual sweep")
    elevation_max_deg = Param(10.0, units="deg", min=-2.0, max=90.0, doc="highest virtual sweep")
    elevation_step_deg = Param(
        0.25,
        units="deg",
        min=0.01,
        max=10.0,
        doc="spacing of the virtual sweeps (finer than the beam to resolve it)",
    )
    elevation_margin_deg = Param(
        2.0,
        units="deg",
        min=0.0,
        max=45.0,
        doc="virtual sweeps reach this far below and above the scan's elevations (the "
        "pattern's support in elevation that matters)",
    )
    elevation_interpolation = Param(
        "linear", type="str", choices=INTERPOLATIONS, doc="between virtual sweeps"
    )
    radial_width_deg = Param(0.5, units="deg", min=0.01, max=10.0, doc="radial spacing")
    gate_width_m = Param(250.0, units="m", min=1.0, max=10_000.0, doc="gate spacing")
    max_range_m = Param(100_000.0, units="m", min=1000.0, max=1e6, doc="range of the last gate")
    azimuth_start_deg = Param(
        None, units="deg", min=0.0, max=360.0, optional=True, doc="sample from this azimuth"
    )
    azimuth_stop_deg = Param(
        None, units="deg", min=0.0, max=360.0, optional=True, doc="sample up to this azimuth"
    )
    margin_deg = Param(10.0, units="deg", min=0.0, max=180.0, doc="radials beyond the sector")
    fields = Param(
        None,
        type="mapping",
        choices=MOMENT_FIELDS,
        optional=True,
        doc="moment -> the file's variable holding it, for names not known (e.g. {DBZH: "
        "dbz_model}); the other moments by name; unset: all by name",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        out = []
        if not params.get("path"):
            out.append(("parameter 'path'", "needs the gridded field's file"))
        xy = [params.get("x_m") is None, params.get("y_m") is None]
        ll = [params.get("latitude") is None, params.get("longitude") is None]
        if all(xy) and all(ll):
            out.append(
                ("parameter 'x_m'", "place the radar: x_m and y_m, or latitude and longitude")
            )
        elif any(xy) != all(xy) or any(ll) != all(ll):
            out.append(("parameter 'x_m'", "give both x_m and y_m (or latitude and longitude)"))
        low = params.get("elevation_min_deg", cls.params["elevation_min_deg"].default)
        high = params.get("elevation_max_deg", cls.params["elevation_max_deg"].default)
        if low > high:
            out.append(("parameter 'elevation_min_deg'", f"{low:g} is above elevation_max_deg"))
        return out

    def load(self) -> Any:
        grid = open_grid(self.p["path"], self.p["fields"])
        p = self.p
        if grid.kind == "cartesian":
            if p["x_m"] is None:
                raise ValueError(
                    f"gridded truth {grid.source}: the grid is Cartesian (x, y); place the "
                    "radar with x_m and y_m"
                )
            site = (float(p["y_m"]), float(p["x_m"]))
        else:
            if p["latitude"] is None:
                raise ValueError(
                    f"gridded truth {grid.source}: the grid is geographic (lat, lon); place "
                    "the radar with latitude and longitude"
                )
            lon = float(p["longitude"])
            site = (float(p["latitude"]), lon + 360.0 if lon < grid.axes[2][0] else lon)
        if not grid.inside(float(p["altitude_m"]), *site):
            z, y, x = grid.axes
            raise ValueError(
                f"gridded truth {grid.source}: the radar at ({site[0]:g}, {site[1]:g}), "
                f"{p['altitude_m']:g} m is outside the grid ({y[0]:g} to {y[-1]:g}, {x[0]:g} "
                f"to {x[-1]:g}, {z[0]:g} to {z[-1]:g} m)"
            )
        return grid, site

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        import warnings

        grid, site = chunk.resource
        p = self.p
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
        sampled = [self._sweep(grid, site, float(e), azimuth, rng, width) for e in elevations]
        winds = [w for _, _, w in sampled if w is not None]
        sweeps = [s for s, _, _ in sampled]
        reference = min(sweeps, key=lambda s: abs(s.elevation_deg - p["elevation_deg"]))
        variables, attrs = volume_variables(sweeps, reference, p["elevation_interpolation"], step)
        for i, k in enumerate(WIND_KEYS if winds else ()):
            variables[f"volume_{k}_wind"] = (
                ("sweep", "radial", "gate"),
                np.stack([np.nan_to_num(w[i]) for w in winds]).astype(np.float32),
                {"units": "m s-1"},
            )
        outside = sum(n for _, n, _ in sampled)
        if outside:
            warnings.warn(
                f"truth {grid.source}: {outside} of the {rng.size * azimuth.size * len(sweeps)} "
                "sampled gates lie outside the grid and have no echo",
                RunNote,
                stacklevel=2,
            )
        lat, lon = site if grid.kind == "geographic" else (0.0, 0.0)
        ds = truth_dataset(
            reference.fields,
            azimuth,
            rng,
            elevation_deg=reference.elevation_deg,
            radial_width_deg=width,
            gate_width_m=float(p["gate_width_m"]),
            nyquist_velocity_ms=float("nan"),
            polarimetric=int(reference.polarimetric),
            source=grid.source,
            time_coverage_start="2000-01-01T00:00:00Z",
            latitude=float(lat),
            longitude=float(lon),
            altitude=float(p["altitude_m"]),
            instrument_name="gridded",
        )
        ds = ds.assign(variables)
        ds.attrs.update(attrs)
        return {"truth": ds}

    def _sweep(
        self,
        grid: Grid,
        site: tuple[float, float],
        elevation: float,
        azimuth: np.ndarray,
        rng: np.ndarray,
        width: float,
    ) -> tuple[TruthSweep, int, tuple[np.ndarray, ...] | None]:
        """One virtual sweep, how many of its gates lie outside the grid, and the wind at its
        gates (east, north, up; None without one)."""
        z = (self.p["altitude_m"] + beam_height(rng, elevation))[None, :]
        s = ground_range(rng, elevation)[None, :]
        az = azimuth[:, None]
        if grid.kind == "cartesian":
            y = site[0] + s * np.cos(np.deg2rad(az))
            x = site[1] + s * np.sin(np.deg2rad(az))
        else:
            y, x = destination(site[0], site[1], az, s)
            x = np.where(x < grid.axes[2][0], x + 360.0, x)  # grids on 0..360 longitudes
        z = np.broadcast_to(z, y.shape)
        outside = np.zeros(y.shape, bool)
        for axis, v in zip(grid.axes, (z, y, x), strict=True):
            outside |= (v < axis[0]) | (v > axis[-1])
        sampled = grid.sample(z, y, x)
        winds = None
        wind = {k: sampled.pop(f"{k}_wind", None) for k in WIND_KEYS}
        if wind["eastward"] is not None:
            # The ray crosses the gate at el + s / (k a); its azimuth there is the radial's on
            # a Cartesian grid, the great circle's final bearing on a geographic one.
            ray_az = np.broadcast_to(az, y.shape)
            if grid.kind == "geographic":
                ray_az = np.where(s > 0, distance_bearing(site[0], site[1], y, x)[2], ray_az)
            east, north = wind["eastward"], wind["northward"]
            assert north is not None  # u and v come together (Grid)
            up = wind["upward"] if wind["upward"] is not None else np.zeros_like(east)
            sampled["VRADH"] = project_wind(
                east, north, up, ray_az, elevation + np.rad2deg(s / (K_EARTH * EARTH_RADIUS_M))
            ).astype(np.float32)
            winds = (east, north, up)
        sweep = TruthSweep(
            azimuth_deg=azimuth,
            elevation_deg=elevation,
            range_m=rng,
            radial_width_deg=width,
            gate_width_m=float(self.p["gate_width_m"]),
            fields=clean_fields(sampled),
            nyquist_velocity_ms=float("nan"),
            site={},
            source=grid.source,
        )
        return sweep, int(outside.sum()), winds
