"""Antennas whose pattern is symmetric about the beam axis: the pencil beam and the ideal
Gaussian."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Input, Output, Param

from ..signals import BEAMS, PATTERN, POLARIZATIONS
from .antenna import Antenna
from .base import PATTERN_SUPPORT, offsets, pattern_dataset, two_way_solid_angle


class AxisymmetricAntenna(Antenna):
    """Base of antennas whose pattern depends only on the angle off the beam axis.

    Subclasses give ``amplitude_off_axis(theta_deg)`` (the one-way field, 1 on the axis); the
    pattern on the offset grid is computed once per beam elevation (azimuth offsets shrink
    into smaller angles as the beam rises, by cos el), H and V are identical, there is no
    cross-polar field and the antenna is steered mechanically, so every beam at one elevation
    has the same pattern.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V power patterns around each beam axis")

    beamwidth_deg = Param(1.0, units="deg", min=0.01, max=30.0, doc="one-way 3-dB beamwidth")
    gain_db = Param(45.5, units="dB", min=0.0, max=70.0, doc="peak gain")
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    @classmethod
    def warm_up(cls) -> None:
        from . import aperture  # noqa: F401

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def power_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.amplitude_off_axis(theta_deg) ** 2

    def setup(self) -> None:
        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self._by_elevation: dict[float, np.ndarray] = {}
        self.omega = two_way_solid_angle(self._power(0.0), self.d_az, self.d_el, 0.0)

    def broadside(self) -> tuple[float, float]:
        """Direction of the beam axis the pattern command calls broadside (az, el)."""
        return 0.0, 0.0

    def pattern_gain_db(self, resource: Any = None) -> float:
        """Peak gain the pattern is normalised to (dBi)."""
        return float(self.p["gain_db"])

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        """One-way fields of both ports at absolute directions, for a beam at (az, el)."""
        from .geometry import DualPolField

        theta = _off_axis_deg(steer_az_deg, steer_el_deg, az_deg, el_deg)
        a = self.amplitude_off_axis(theta).astype(complex)
        zero = np.zeros_like(a)
        return DualPolField(h_co=a, h_cross=zero, v_co=a, v_cross=zero)

    def _power(self, elevation_deg: float) -> np.ndarray:
        if elevation_deg not in self._by_elevation:
            theta = _off_axis_deg(
                0.0, elevation_deg, self.d_az[None, :], elevation_deg + self.d_el[:, None]
            )
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


def _off_axis_deg(
    axis_az_deg: float, axis_el_deg: float, az_deg: np.ndarray, el_deg: np.ndarray
) -> np.ndarray:
    """Great-circle angle between the axis and each direction, degrees."""
    el0 = np.deg2rad(axis_el_deg)
    el = np.deg2rad(np.asarray(el_deg, dtype=float))
    d_az = np.deg2rad(np.asarray(az_deg, dtype=float) - axis_az_deg)
    cos_t = np.sin(el0) * np.sin(el) + np.cos(el0) * np.cos(el) * np.cos(d_az)
    return np.rad2deg(np.arccos(np.clip(cos_t, -1.0, 1.0)))


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
        from .aperture import PencilBeam

        self.beam = PencilBeam.design(self.p["beamwidth_deg"], self.p["first_sidelobe_db"])
        super().setup()

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.beam.amplitude(theta_deg)


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

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        amplitude = np.exp(-2 * np.log(2) * (theta_deg / self.p["beamwidth_deg"]) ** 2)
        return np.where(theta_deg > self.p["support_deg"], 0.0, amplitude)
