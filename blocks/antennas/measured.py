"""The measured antenna: a mechanically steered antenna whose pattern is read from a file
(the format is in :mod:`pasim_blocks.antennas.pattern_files`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph import Chunk, Input, Output, Param

from ..signals import BEAMS, PATTERN, POLARIZATIONS
from .antenna import Antenna
from .base import offsets, pattern_dataset, two_way_solid_angle
from .pattern_files import TabulatedPattern, read_pattern_file


class MeasuredAntenna(Antenna):
    """A mechanically steered antenna whose pattern is read from a file (measured or simulated).

    The file gives both ports' co- and cross-polar complex gains around the boresight (format
    in ``pasim_blocks.antennas.pattern_files`` and docs/arrays.md). For a beam at elevation el_b
    each grid direction is turned into the antenna's frame (rotated up by el_b) and the table
    is interpolated there; the polarisation basis is taken as the antenna's (its rotation off
    the axis is second order in the offsets). Every beam at one elevation has the same pattern,
    so the boresight calibration is the per-beam one.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V co- and cross-polar patterns per beam")

    path = Param(None, type="path", doc="pattern file (format in docs/arrays.md)")
    gain_db = Param(
        None,
        units="dB",
        min=-20.0,
        max=80.0,
        optional=True,
        doc="peak gain (unset: the file's largest H co-polar gain)",
    )
    support_deg = Param(
        10.0, units="deg", min=0.5, max=45.0, doc="half-width of the pattern grid around the axis"
    )
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    transient = ("_memo",)

    @classmethod
    def warm_up(cls) -> None:
        import scipy.interpolate  # noqa: F401

    def setup(self) -> None:
        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self._memo: dict[float, tuple[np.ndarray, np.ndarray]] | None = {}

    def load(self) -> TabulatedPattern:
        return read_pattern_file(self.p["path"])

    def broadside(self) -> tuple[float, float]:
        return 0.0, 0.0

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: Any,
        el_deg: Any,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        """Fields at absolute directions for the antenna pointed at (az, el)."""
        el0 = np.deg2rad(steer_el_deg)
        el = np.deg2rad(np.asarray(el_deg, float))
        d_az = np.deg2rad(np.asarray(az_deg, float) - steer_az_deg)
        x, y, z = np.cos(el) * np.sin(d_az), np.cos(el) * np.cos(d_az), np.sin(el)
        # Into the antenna frame: rotate about the horizontal axis by -el0.
        y_a = y * np.cos(el0) + z * np.sin(el0)
        z_a = -y * np.sin(el0) + z * np.cos(el0)
        az_a = np.rad2deg(np.arctan2(x, y_a))
        el_a = np.rad2deg(np.arcsin(np.clip(z_a, -1.0, 1.0)))
        return resource.fields(az_a, el_a, normalise="peak")

    def pattern_gain_db(self, resource: Any = None) -> float:
        return self.gain(resource)

    def gain(self, resource: TabulatedPattern) -> float:
        return float(resource.peak_gain_db if self.p["gain_db"] is None else self.p["gain_db"])

    def _grid(self, el_deg: float, resource: TabulatedPattern) -> tuple[np.ndarray, np.ndarray]:
        if self._memo is None:
            self._memo = {}
        if el_deg not in self._memo:
            f = self.fields_at(
                0.0, el_deg, self.d_az[None, :], el_deg + self.d_el[:, None], 0, resource
            )
            shape = (self.d_el.size, self.d_az.size)
            co = np.stack([np.broadcast_to(f.h_co, shape), np.broadcast_to(f.v_co, shape)])
            cross = np.stack([np.broadcast_to(f.h_cross, shape), np.broadcast_to(f.v_cross, shape)])
            self._memo[el_deg] = (co, cross)
        return self._memo[el_deg]

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        table = chunk.resource
        reference, _ = self._grid(0.0, table)
        ref_power = np.abs(reference) ** 2
        omega = {
            p: two_way_solid_angle(ref_power[i], self.d_az, self.d_el, 0.0)
            for i, p in enumerate(POLARIZATIONS)
        }
        grids = [self._grid(float(e), table) for e in inputs["beams"]["elevation"].values]
        co = np.stack([g[0] for g in grids])
        cross = np.stack([g[1] for g in grids])
        ds = pattern_dataset(
            (co.real**2 + co.imag**2).astype(np.float32),
            self.d_az,
            self.d_el,
            self.gain(table),
            omega,
            co_polar=co,
            cross_polar=cross,
            antenna=f"measured ({Path(table.source).name})",
        )
        return {"pattern": ds}
