"""Ground clutter: a clutter map seen through the antenna's two-way pattern, added to the echo.

The map gives each cell of the truth's polar grid a clutter-equivalent reflectivity Z_c (dBZ):
what this radar's calibration would report for the clutter if it were alone. It comes from a
file (``source`` file: a NetCDF with a variable ``clutter_dbz`` on the truth's radial x gate
grid), from a uniform value (``uniform``: ``clutter_dbz`` everywhere inside ``extent_m``) or
from a statistical near-range model (``model``): every cell nearer than ``extent_m`` is
clutter with probability ``coverage``, and a clutter cell's Z_c in dBZ is normal with mean
``clutter_dbz - range_decay_db_per_km x r`` and standard deviation ``std_db`` (log-normal
power: the standard land-clutter amplitude statistics, Nathanson 1991 and Billingsley 2002,
with a range fall-off for the terrain the beam clears). The model's map is drawn once per run
from the run's seed, on the whole grid, so it does not depend on the chunking.

Each beam weights the map's radials by the two-way H and V patterns integrated over their
azimuth extent (as the weather channel weights the weather: sidelobes included; the map is
taken at the sweep's elevation, as a clutter map measured by the radar at that elevation is),
so a uniform map of Z_c gives back Z_c through the radar constant. Per gate, the clutter is a
Gaussian process centred on zero velocity with spectrum width
sigma_c = sqrt(sigma_veg^2 + sigma_scan^2): ``vegetation_width_ms`` for wind-blown
vegetation, and for a rotating antenna the scan modulation
sigma_scan = alpha lambda sqrt(ln 2) / (2 pi theta_1) (Doviak and Zrnic 1993, eq. 5.38; alpha
the azimuth rate in rad/s, theta_1 the one-way 3-dB beamwidth in rad, measured on the
pattern), zero for a beam steered electronically (the beam stands still during its dwell).
H and V clutter have their own ZDR, correlation coefficient and differential phase. The
series follow the dwell's pulse times (uniform or staggered PRT) and carry each pulse's
transmit phase (phase-coded scans): the clutter is a first-trip echo.
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..angles import circular_difference
from ..signals import BEAMS, CALIBRATION, IQ, PATTERN, TRUTH, check_pulses
from ..timing import code_errors, prt_ratio, pulse_times, transmit_phase
from .beams import azimuth_profile, cell_solid_angles

#: Antennas whose beam moves with the dish during a dwell (pattern ``antenna`` attribute).
ROTATING = ("antenna.pencil", "antenna.ideal", "PencilBeamAntenna", "IdealAntenna")


def scan_modulation_width(rate_deg_s: float, wavelength_m: float, beamwidth_deg: float) -> float:
    """sigma_scan = alpha lambda sqrt(ln 2) / (2 pi theta_1) (Doviak and Zrnic 1993)."""
    return float(
        np.deg2rad(rate_deg_s)
        * wavelength_m
        * np.sqrt(np.log(2))
        / (2 * np.pi * np.deg2rad(beamwidth_deg))
    )


def one_way_beamwidth(power: np.ndarray, d_az_deg: np.ndarray, d_el_deg: np.ndarray) -> float:
    """3-dB azimuth width (deg) of a one-way power pattern (elevation x azimuth offset), on
    the row nearest the beam axis, by linear interpolation of the half-power crossings."""
    row = power[int(np.argmin(np.abs(d_el_deg)))].astype(np.float64)
    row = row / row.max()
    peak = int(np.argmax(row))
    above = row >= 0.5
    lo = peak
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = peak
    while hi < row.size - 1 and above[hi + 1]:
        hi += 1
    if lo == 0 or hi == row.size - 1:
        return float(d_az_deg[-1] - d_az_deg[0])

    def cross(a: int, b: int) -> float:
        return float(np.interp(0.5, [row[a], row[b]], [d_az_deg[a], d_az_deg[b]]))

    return cross(hi + 1, hi) - cross(lo - 1, lo)


def clutter_factor(times_s: np.ndarray, width_ms: float, wavelength_m: float) -> np.ndarray:
    """L with L L^H = the pulse-to-pulse correlation exp(-8 (pi sigma (t_m - t_n) / lambda)^2)
    of a zero-velocity Gaussian spectrum; from the eigendecomposition, exact to round-off even
    for the nearly singular correlation of a very narrow spectrum (no diagonal jitter)."""
    lag = times_s[:, None] - times_s[None, :]
    cov = np.exp(-8 * (np.pi * width_ms * lag / wavelength_m) ** 2)
    vals, vecs = np.linalg.eigh(cov)
    return vecs * np.sqrt(np.clip(vals, 0.0, None))[None, :]


class GroundClutter(Block):
    """Ground clutter from a clutter map, through the two-way pattern, added to the echo.

    See the module's documentation for the map (file, uniform or statistical near-range
    model), the spectrum (vegetation and, for a rotating antenna, scan modulation) and the
    polarimetry. ``antenna_motion`` ``auto`` takes the pencil and ideal antennas as rotating
    dishes and the arrays (planar, cylindrical) as electronically steered.
    """

    iq_in = Input(IQ, doc="echo voltages (weather) to add the clutter to")
    truth = Input(TRUTH, doc="truth sweep: the polar grid of the clutter map")
    beams = Input(BEAMS, doc="beam geometry, pulse timing and scan rate")
    pattern = Input(PATTERN, doc="one-way H and V power patterns")
    calibration = Input(CALIBRATION, doc="the weather channel's radar constant")
    iq = Output(IQ, doc="echo voltages with the clutter added")

    source = Param(
        "model",
        type="str",
        choices=("model", "uniform", "file"),
        doc="clutter map: statistical near-range model, uniform, or a file",
    )
    path = Param("", type="path", doc="NetCDF clutter map (variable clutter_dbz; source file)")
    clutter_dbz = Param(
        50.0,
        units="dBZ",
        min=-50.0,
        max=120.0,
        doc="clutter-equivalent reflectivity (uniform), or its mean at zero range (model)",
    )
    extent_m = Param(
        40_000.0, units="m", min=0.0, max=1e6, doc="no clutter beyond this range (model, uniform)"
    )
    range_decay_db_per_km = Param(
        1.0, units="dB/km", min=0.0, max=20.0, doc="fall-off of the model's mean with range"
    )
    std_db = Param(10.0, units="dB", min=0.0, max=40.0, doc="spread of the model's cells (dB)")
    coverage = Param(0.5, min=0.0, max=1.0, doc="fraction of the model's cells with clutter")
    vegetation_width_ms = Param(
        0.1, units="m/s", min=0.0, max=2.0, doc="spectrum width of wind-blown vegetation"
    )
    antenna_motion = Param(
        "auto",
        type="str",
        choices=("auto", "rotating", "electronic"),
        doc="rotating antenna (scan modulation) or electronically steered beam (none)",
    )
    zdr_db = Param(0.0, units="dB", min=-20.0, max=20.0, doc="differential reflectivity of clutter")
    rho_hv = Param(0.7, min=0.0, max=1.0, doc="H-V correlation coefficient of clutter")
    phidp_deg = Param(0.0, units="deg", min=-360.0, max=360.0, doc="differential phase of clutter")

    transient = ("_map",)

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        if params.get("source") == "file" and not params.get("path"):
            return [("parameter 'path'", "source 'file' needs the clutter map's path")]
        return []

    def setup(self) -> None:
        self._map: tuple[Any, np.ndarray] | None = None

    def load(self) -> Any:
        if self.p["source"] != "file":
            return None
        with xr.open_dataset(self.p["path"]) as ds:
            if "clutter_dbz" not in ds:
                raise ValueError(
                    f"clutter map {self.p['path']}: no variable 'clutter_dbz' (radial x gate)"
                )
            return np.asarray(ds["clutter_dbz"].values, np.float64)

    def clutter_map(self, truth: xr.Dataset, seed: int, resource: Any = None) -> np.ndarray:
        """Z_c (dBZ, NaN: none) on the truth's radial x gate grid."""
        shape = (truth.sizes["radial"], truth.sizes["gate"])
        rng_m = truth["range"].values
        if self.p["source"] == "file":
            if resource is None or resource.shape != shape:
                got = None if resource is None else resource.shape
                raise ValueError(
                    f"clutter map {self.p['path']}: shape {got} is not the truth's {shape}"
                )
            return resource
        inside = np.broadcast_to(rng_m <= self.p["extent_m"], shape)
        if self.p["source"] == "uniform":
            return np.where(inside, self.p["clutter_dbz"], np.nan)
        gen = np.random.default_rng(
            np.random.SeedSequence([seed, zlib.crc32(self.name.encode()), 0xC1])
        )
        mean = self.p["clutter_dbz"] - self.p["range_decay_db_per_km"] * rng_m / 1e3
        dbz = mean[None, :] + self.p["std_db"] * gen.standard_normal(shape)
        present = inside & (gen.uniform(size=shape) < self.p["coverage"])
        return np.where(present, dbz, np.nan)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        iq_in, truth, beams = inputs["iq_in"], inputs["truth"], inputs["beams"]
        pattern, cal = inputs["pattern"], inputs["calibration"]
        check_pulses(iq_in, chunk, self.name)
        if chunk.expected:
            raise ValueError(
                f"block '{self.name}': the I/Q cube has no pulses (weather method 'expected'): "
                "ground clutter needs time series (method combined, covariance or monte_carlo)"
            )
        n_g, pulses = iq_in.shape[1:3]
        if truth.sizes["gate"] != n_g:
            raise ValueError(f"truth has {truth.sizes['gate']} gates, the I/Q {n_g}")
        key = (id(truth), chunk.seed)
        if self._map is None or self._map[0] != key:
            self._map = (key, self.clutter_map(truth, chunk.seed, chunk.resource))
        z_lin = np.nan_to_num(10 ** (self._map[1] / 10), nan=0.0)
        lam = float(cal.attrs["wavelength_m"])
        prt = float(beams["prt"].values[0])
        times = pulse_times(prt, pulses, prt_ratio(beams))
        psi = transmit_phase(beams, pulses)
        errors = code_errors(beams, pulses) if psi is not None else None
        rng_m = truth["range"].values
        az_truth = truth["azimuth"].values
        width_deg = float(truth.attrs["radial_width_deg"])
        d_az = pattern["azimuth_offset_deg"].values
        d_el = pattern["elevation_offset_deg"].values
        support = max(abs(d_az[0]), abs(d_az[-1])) + width_deg / 2
        motion = self.p["antenna_motion"]
        if motion == "auto":
            motion = "rotating" if str(pattern.attrs["antenna"]) in ROTATING else "electronic"
        const = 10 ** (cal["radar_constant_db"].values / 10)  # beam x pol
        omega_cal = pattern["calibration_solid_angle_sr"].values
        blind = rng_m < float(cal.attrs["blind_range_m"])
        zdr = 10 ** (self.p["zdr_db"] / 10)
        rho = float(self.p["rho_hv"])
        out = np.array(iq_in, copy=True)
        for i, beam in enumerate(chunk.beams):
            az_b = float(beams["azimuth"].values[i])
            el_b = float(beams["elevation"].values[i])
            delta = circular_difference(az_truth, np.asarray(az_b), 360.0)
            near = np.flatnonzero(np.abs(delta) <= support)
            profile = azimuth_profile(pattern["power"].values[i], d_el, el_b)
            omega = cell_solid_angles(profile, d_az, delta[near], width_deg)  # pol x radial
            p_h = const[i, 0] / rng_m**2 * (omega[0] @ z_lin[near]) / omega_cal[i, 0]
            p_v = const[i, 1] / rng_m**2 * (omega[1] @ z_lin[near]) / omega_cal[i, 1] / zdr
            p_h[blind] = 0.0
            p_v[blind] = 0.0
            sigma = self.p["vegetation_width_ms"]
            if motion == "rotating" and "scan_rate" in beams:
                theta = one_way_beamwidth(pattern["power"].values[i, 0], d_az, d_el)
                sigma_scan = scan_modulation_width(float(beams["scan_rate"].values[i]), lam, theta)
                sigma = float(np.hypot(sigma, sigma_scan))
            factor = clutter_factor(times, sigma, lam)
            gen_h, gen_v = chunk.rng(int(beam)), chunk.rng(int(beam), 1)
            gates = np.flatnonzero(p_h > 0)
            if not gates.size:
                continue
            z1 = _complex_normal(gen_h, (gates.size, pulses)) @ factor.T
            z2 = _complex_normal(gen_v, (gates.size, pulses)) @ factor.T
            code = np.exp(1j * psi[i]) if psi is not None else 1.0
            if errors is not None and psi is not None:  # the echo carries what was sent
                code = errors[1][i] * np.exp(1j * (psi[i] + errors[0][i]))
            h = np.sqrt(p_h[gates])[:, None] * z1 * code
            v = (
                np.sqrt(p_v[gates])[:, None]
                * (rho * z1 + np.sqrt(1 - rho**2) * z2)
                * np.exp(1j * np.deg2rad(self.p["phidp_deg"]))
                * code
            )
            out[i, gates, :, 0] += h.astype(out.dtype)
            out[i, gates, :, 1] += v.astype(out.dtype)
        return {"iq": out}


def _complex_normal(gen: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    return (gen.standard_normal(shape) + 1j * gen.standard_normal(shape)) * np.sqrt(0.5)
