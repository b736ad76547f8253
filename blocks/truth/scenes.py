"""Synthetic scenes: truth fields made from parameters, for studying estimators alone."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Output, Param

from ..signals import TRUTH
from .nexrad import truth_dataset

FIELD_PARAMS = {
    "DBZH": "reflectivity_dbz",
    "VRADH": "velocity_ms",
    "WRADH": "spectrum_width_ms",
    "ZDR": "differential_reflectivity_db",
    "RHOHV": "cross_correlation_ratio",
    "PHIDP": "differential_phase_deg",
}


class UniformScene(Block):
    """The same six moments at every gate of a full-circle polar grid.

    Values are taken as given, including the unphysical ones (rho_hv above 1, widths of 0,
    velocities beyond any Nyquist interval), so that the chain's handling of extremes can be
    studied; the weather channel decides what it can draw.
    """

    truth = Output(TRUTH, doc="uniform truth fields")

    reflectivity_dbz = Param(30.0, units="dBZ", min=-60.0, max=100.0, doc="reflectivity")
    velocity_ms = Param(5.0, units="m/s", min=-200.0, max=200.0, doc="radial velocity")
    spectrum_width_ms = Param(2.0, units="m/s", min=0.0, max=50.0, doc="spectrum width")
    differential_reflectivity_db = Param(1.0, units="dB", min=-8.0, max=8.0, doc="ZDR")
    cross_correlation_ratio = Param(0.98, min=0.0, max=1.1, doc="rho_hv")
    differential_phase_deg = Param(30.0, units="deg", min=-720.0, max=720.0, doc="phi_DP")
    gates = Param(100, type="int", min=1, max=100_000, doc="number of range gates")
    gate_width_m = Param(250.0, units="m", min=1.0, max=10_000.0, doc="gate spacing")
    first_gate_m = Param(20_000.0, units="m", min=1.0, max=1e6, doc="range of the first gate")
    radial_width_deg = Param(0.5, units="deg", min=0.01, max=10.0, doc="radial spacing")
    elevation_deg = Param(0.5, units="deg", min=-2.0, max=90.0, doc="elevation of the sweep")
    masked = Param(False, type="bool", doc="no echo anywhere: every gate masked, as in clear air")

    def fields(self, azimuth: np.ndarray, rng_m: np.ndarray) -> dict[str, np.ndarray]:
        shape = (azimuth.size, rng_m.size)
        return {
            name: np.full(shape, np.nan if self.p["masked"] else self.p[param], np.float32)
            for name, param in FIELD_PARAMS.items()
        }

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        n_radials = max(1, round(360.0 / self.p["radial_width_deg"]))
        width = 360.0 / n_radials
        azimuth = (np.arange(n_radials) + 0.5) * width
        rng_m = self.p["first_gate_m"] + self.p["gate_width_m"] * np.arange(self.p["gates"])
        ds = truth_dataset(
            self.fields(azimuth, rng_m),
            azimuth,
            rng_m,
            elevation_deg=float(self.p["elevation_deg"]),
            radial_width_deg=width,
            gate_width_m=float(self.p["gate_width_m"]),
            nyquist_velocity_ms=float("nan"),
            polarimetric=1,
            source=self.type_name or type(self).__name__,
            time_coverage_start="2000-01-01T00:00:00Z",
            latitude=0.0,
            longitude=0.0,
            altitude=0.0,
            instrument_name="synthetic",
        )
        return {"truth": ds}


class CoreScene(UniformScene):
    """A uniform scene with a reflectivity core: a sharp gradient for contamination studies.

    Inside the azimuth and range box of the core the reflectivity is ``core_dbz``; everywhere
    else it is ``reflectivity_dbz`` (for example 60 dBZ next to 0 dBZ). The other moments are
    uniform.
    """

    reflectivity_dbz = Param(
        0.0, units="dBZ", min=-60.0, max=100.0, doc="reflectivity outside the core"
    )
    core_dbz = Param(60.0, units="dBZ", min=-60.0, max=100.0, doc="reflectivity of the core")
    core_azimuth_start_deg = Param(
        10.0, units="deg", min=0.0, max=360.0, doc="core starts at this azimuth (clockwise)"
    )
    core_azimuth_stop_deg = Param(20.0, units="deg", min=0.0, max=360.0, doc="core ends here")
    core_range_start_m = Param(0.0, units="m", min=0.0, max=1e6, doc="core starts at range")
    core_range_stop_m = Param(1e6, units="m", min=0.0, max=1e6, doc="core ends at range")

    def fields(self, azimuth: np.ndarray, rng_m: np.ndarray) -> dict[str, np.ndarray]:
        out = super().fields(azimuth, rng_m)
        a0, a1 = self.p["core_azimuth_start_deg"], self.p["core_azimuth_stop_deg"]
        in_az = (azimuth - a0) % 360.0 <= (a1 - a0) % 360.0
        in_rng = (rng_m >= self.p["core_range_start_m"]) & (rng_m <= self.p["core_range_stop_m"])
        out["DBZH"][np.ix_(in_az, in_rng)] = self.p["core_dbz"]
        return out
