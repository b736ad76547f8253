"""The antenna contract: what a run, ``pasim pattern`` and a study need of an antenna block.

A new antenna is one class deriving from :class:`Antenna` that gives the abstract methods:
``fields_at`` (its one-way fields at any direction for a beam steered anywhere), ``broadside``,
``pattern_gain_db`` and ``process`` (the pattern port of a chunk; :meth:`Antenna.sampled_pattern`
builds it from ``fields_at``). The registry refuses, naming the method, a class that leaves one
out, so a missing method is found when the plugin loads, not in the middle of a study. The
pattern command and the study call only the methods declared here (``prepare`` and
``ideal_copy`` have defaults an antenna overrides when it needs to).
"""

from __future__ import annotations

import abc
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output

from ..signals import BEAMS, PATTERN, POLARIZATIONS
from .base import pattern_dataset, steering, two_way_solid_angle
from .geometry import DualPolField

__all__ = ["Antenna", "DualPolField"]


class Antenna(Block, abc.ABC):
    """Base of every antenna: one-way H and V patterns around each beam's axis.

    Declares the two ports every antenna has (the beams in, the pattern out) and the methods
    the pattern command and studies measure it with.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V patterns around each beam axis")

    @abc.abstractmethod
    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> DualPolField:
        """One-way complex fields of both ports at absolute directions (``az_deg``,
        ``el_deg``, degrees, any broadcastable shapes) for the beam steered to
        (``steer_az_deg``, ``steer_el_deg``): a :class:`DualPolField` (``h_co``,
        ``h_cross``, ``v_co``, ``v_cross``, broadcastable arrays), normalised so that the
        power is 1 at the peak gain :meth:`pattern_gain_db`. ``seed`` is the run seed (an
        antenna with random channel errors draws them from it); ``resource`` what
        :meth:`load` returned."""

    @abc.abstractmethod
    def broadside(self) -> tuple[float, float]:
        """The direction (azimuth, elevation, degrees) the pattern command calls broadside:
        its ``--steer`` offsets are from here."""

    @abc.abstractmethod
    def pattern_gain_db(self, resource: Any = None) -> float:
        """The peak gain (dBi) the patterns are normalised to."""

    @abc.abstractmethod
    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        """``{"pattern": ...}`` for the chunk's beams (``inputs["beams"]``); see
        :meth:`sampled_pattern`."""

    def prepare(self, resource: Any) -> None:
        """Derive what needs the loaded resource (an element pattern file, ...) before
        :meth:`fields_at` is called outside a run; the default needs nothing."""

    def ideal_copy(self) -> Antenna | None:
        """The same antenna with ideal channel electronics, the design its errors perturb
        (None: it has no errors, as the default says)."""
        return None

    def sampled_pattern(
        self,
        beams: xr.Dataset,
        d_az: np.ndarray,
        d_el: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> xr.Dataset:
        """The pattern port's Dataset for ``beams``: :meth:`fields_at` sampled on the offsets
        ``d_az`` x ``d_el`` (degrees) from each beam's axis, calibrated at broadside (every
        beam gets the broadside two-way solid angle)."""

        def grid(az: float, el: float) -> tuple[np.ndarray, np.ndarray]:
            f = self.fields_at(az, el, az + d_az[None, :], el + d_el[:, None], seed, resource)
            shape = (d_el.size, d_az.size)
            co = np.stack([np.broadcast_to(f.h_co, shape), np.broadcast_to(f.v_co, shape)])
            cross = np.stack([np.broadcast_to(f.h_cross, shape), np.broadcast_to(f.v_cross, shape)])
            return co, cross

        az0, el0 = self.broadside()
        co0, _ = grid(az0, el0)
        power0 = np.abs(co0) ** 2
        omega = {
            p: two_way_solid_angle(power0[i], d_az, d_el, el0) for i, p in enumerate(POLARIZATIONS)
        }
        grids = [grid(float(a), float(e)) for a, e in zip(*steering(beams), strict=True)]
        empty = np.zeros((0, 2, d_el.size, d_az.size), complex)
        co = np.stack([g[0] for g in grids]) if grids else empty
        cross = np.stack([g[1] for g in grids]) if grids else empty
        return pattern_dataset(
            (np.abs(co) ** 2).astype(np.float32),
            d_az,
            d_el,
            self.pattern_gain_db(resource),
            omega,
            co_polar=co,
            cross_polar=cross,
            antenna=self.type_name or type(self).__name__,
        )
