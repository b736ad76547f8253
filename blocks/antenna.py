"""Antennas: one-way H and V power patterns around each beam's axis.

A pattern is sampled on a grid of azimuth and elevation offsets from the beam axis and
normalised to the antenna's peak gain (``gain_db`` attribute), so that scan loss and H/V
mismatch off broadside show as values below 1 and as P_H != P_V. The weather channel squares
it (the same antenna transmits and receives) and integrates it over each truth cell.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from .signals import BEAMS, PATTERN, POLARIZATIONS

#: Parameters several antennas declare alike (each class gets its own named copy).
PATTERN_SUPPORT = Param(
    10.0, units="deg", min=0.5, max=45.0, doc="half-width of the pattern grid around the beam axis"
)
PATCH_SIDE = Param(
    0.0524, units="m", min=1e-3, max=1.0, doc="side of the square patch (paper Table 1)"
)


def offsets(support_deg: float, step_deg: float) -> np.ndarray:
    n = int(np.ceil(support_deg / step_deg))
    return np.arange(-n, n + 1) * step_deg


def two_way_solid_angle(
    power: np.ndarray, d_az: np.ndarray, d_el: np.ndarray, elevation_deg: float
) -> float:
    """Integral of the two-way power pattern over the grid, in steradians."""
    step = np.deg2rad(d_az[1] - d_az[0]) * np.deg2rad(d_el[1] - d_el[0])
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el))[:, None]
    return float(np.sum(power.astype(np.float64) ** 2 * cos_el) * step)


def pattern_dataset(
    power: np.ndarray,
    d_az: np.ndarray,
    d_el: np.ndarray,
    gain_db: float,
    solid_angle_sr: dict[str, float],
    **attrs: Any,
) -> xr.Dataset:
    return xr.Dataset(
        {
            "power": (
                ("beam", "polarization", "elevation_offset", "azimuth_offset"),
                power,
                {"units": "1"},
            ),
            # Boresight calibration: every beam gets the radar constant of the beam at
            # broadside, so scan loss and H/V mismatch off broadside stay in the data.
            "calibration_solid_angle_sr": (
                ("beam", "polarization"),
                np.tile([solid_angle_sr[p] for p in POLARIZATIONS], (power.shape[0], 1)),
                {"units": "sr"},
            ),
        },
        coords={
            "polarization": list(POLARIZATIONS),
            "azimuth_offset_deg": ("azimuth_offset", d_az, {"units": "degrees"}),
            "elevation_offset_deg": ("elevation_offset", d_el, {"units": "degrees"}),
        },
        attrs={
            "gain_db": gain_db,
            "calibration": "boresight",
            **{f"two_way_solid_angle_sr_{p}": v for p, v in solid_angle_sr.items()},
            **attrs,
        },
    )


class AxisymmetricAntenna(Block):
    """Base of antennas whose pattern depends only on the angle off the beam axis.

    Subclasses give ``power_off_axis(theta_deg)``; the pattern on the offset grid is computed
    once per beam elevation (azimuth offsets shrink into smaller angles as the beam rises, by
    cos el), H and V are identical and the antenna is steered mechanically, so every beam at
    one elevation has the same pattern.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V power patterns around each beam axis")

    beamwidth_deg = Param(1.0, units="deg", min=0.01, max=30.0, doc="one-way 3-dB beamwidth")
    gain_db = Param(45.5, units="dB", min=0.0, max=70.0, doc="peak gain")
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    @classmethod
    def warm_up(cls) -> None:
        from . import patterns  # noqa: F401

    def power_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def setup(self) -> None:
        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self._by_elevation: dict[float, np.ndarray] = {}
        self.omega = two_way_solid_angle(self._power(0.0), self.d_az, self.d_el, 0.0)

    def _power(self, elevation_deg: float) -> np.ndarray:
        if elevation_deg not in self._by_elevation:
            el0 = np.deg2rad(elevation_deg)
            el = el0 + np.deg2rad(self.d_el)[:, None]
            d_az = np.deg2rad(self.d_az)[None, :]
            # Great-circle angle between the axis and each direction of the grid.
            cos_t = np.sin(el0) * np.sin(el) + np.cos(el0) * np.cos(el) * np.cos(d_az)
            theta = np.rad2deg(np.arccos(np.clip(cos_t, -1.0, 1.0)))
            self._by_elevation[elevation_deg] = self.power_off_axis(theta).astype(np.float32)
        return self._by_elevation[elevation_deg]

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        elevations = inputs["beams"]["elevation"].values
        shape = (2, self.d_el.size, self.d_az.size)
        power = np.stack([np.broadcast_to(self._power(float(e)), shape) for e in elevations])
        ds = pattern_dataset(
            power,
            self.d_az,
            self.d_el,
            self.p["gain_db"],
            {p: self.omega for p in POLARIZATIONS},
            antenna=self.type_name or type(self).__name__,
        )
        return {"pattern": ds}


class PencilBeamAntenna(AxisymmetricAntenna):
    """A mechanically steered pencil beam: the same pattern at every azimuth (generic radar).

    Circular aperture whose (1 - rho^2)^p taper is solved to give ``first_sidelobe_db``,
    scaled to ``beamwidth_deg``; H and V patterns are identical.
    """

    beamwidth_deg = Param(1.0, units="deg", min=0.1, max=30.0, doc="one-way 3-dB beamwidth")
    first_sidelobe_db = Param(
        -32.0, units="dB", min=-60.0, max=-17.6, doc="first sidelobe level, one-way"
    )
    support_deg = PATTERN_SUPPORT

    def setup(self) -> None:
        from .patterns import PencilBeam

        self.beam = PencilBeam.design(self.p["beamwidth_deg"], self.p["first_sidelobe_db"])
        super().setup()

    def power_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.beam.power(theta_deg)


class IdealAntenna(AxisymmetricAntenna):
    """A pencil beam with no sidelobes: a Gaussian main lobe, for estimator studies.

    One-way power exp(-4 ln 2 theta^2 / beamwidth^2) of the angle theta off the axis, cut to
    zero beyond ``support_deg``; H and V identical.
    """

    support_deg = Param(
        2.0,
        units="deg",
        min=0.05,
        max=45.0,
        doc="half-width of the pattern grid (the beam is zero beyond)",
    )

    def power_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        power = np.exp(-4 * np.log(2) * (theta_deg / self.p["beamwidth_deg"]) ** 2)
        return np.where(theta_deg > self.p["support_deg"], 0.0, power)


class PlanarPatchArray(Block):
    """A uniform planar array of dual-polarised patches, Taylor-tapered, steered electronically.

    Elements sit on an ``n_x`` by ``n_y`` grid in a vertical face whose normal points at
    ``face_azimuth_deg``. Each beam is steered by phase weights; the pattern is normalised to
    the broadside peak, so scan loss, beam broadening and the H/V mismatch that biases ZDR off
    broadside all appear.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V power patterns around each beam axis")

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    n_x = Param(80, type="int", min=1, max=4096, doc="elements across (azimuth)")
    n_y = Param(80, type="int", min=1, max=4096, doc="elements up (elevation)")
    spacing_x_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing across")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    patch_m = PATCH_SIDE
    taylor_sll_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor taper sidelobe level (both axes)"
    )
    taylor_nbar = Param(5, type="int", min=1, max=50, doc="Taylor taper nbar")
    face_azimuth_deg = Param(
        285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the array face normal"
    )
    face_tilt_deg = Param(0.0, units="deg", min=-30.0, max=60.0, doc="upward tilt of the face")
    support_deg = PATTERN_SUPPORT
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    @classmethod
    def warm_up(cls) -> None:
        from . import patterns  # noqa: F401

    def _array(self) -> dict[str, Any]:
        keys = (
            "n_x",
            "n_y",
            "frequency_hz",
            "patch_m",
            "taylor_sll_db",
            "taylor_nbar",
            "face_azimuth_deg",
            "face_tilt_deg",
        )
        kw = {k: self.p[k] for k in keys}
        kw["dx_m"], kw["dy_m"] = self.p["spacing_x_m"], self.p["spacing_y_m"]
        return kw

    def setup(self) -> None:
        from .patterns import planar_array_directivity_db

        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        kw = self._array()
        self.gain_db = planar_array_directivity_db(
            n_x=kw["n_x"],
            n_y=kw["n_y"],
            dx_m=kw["dx_m"],
            dy_m=kw["dy_m"],
            frequency_hz=kw["frequency_hz"],
            taylor_sll_db=kw["taylor_sll_db"],
            taylor_nbar=kw["taylor_nbar"],
        )
        broadside = self._power(self.p["face_azimuth_deg"], self.p["face_tilt_deg"])
        self.omega = {
            p: two_way_solid_angle(broadside[i], self.d_az, self.d_el, self.p["face_tilt_deg"])
            for i, p in enumerate(POLARIZATIONS)
        }

    def _power(self, az_deg: float, el_deg: float) -> np.ndarray:
        from .patterns import planar_array_power

        az = az_deg + self.d_az[None, :]
        el = el_deg + self.d_el[:, None]
        p_h, p_v = planar_array_power(
            az, el, steer_az_deg=az_deg, steer_el_deg=el_deg, **self._array()
        )
        shape = np.broadcast_shapes(az.shape, el.shape)
        return np.stack([np.broadcast_to(p_h, shape), np.broadcast_to(p_v, shape)])

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams"]
        power = np.stack(
            [
                self._power(a, e)
                for a, e in zip(beams["azimuth"].values, beams["elevation"].values, strict=True)
            ]
        )
        ds = pattern_dataset(
            power.astype(np.float32),
            self.d_az,
            self.d_el,
            self.gain_db,
            self.omega,
            antenna="planar",
        )
        return {"pattern": ds}
