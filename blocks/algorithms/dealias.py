"""Velocity dealiasing: Py-ART's region-based and unwrap-phase methods on the whole sweep."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import MOMENTS, SCORES
from .sweep_radar import (
    ALGORITHM_FIELDS,
    add_field,
    filled,
    make_radar,
    need,
    product,
    pyart,
    scored_gates,
)

#: Py-ART 2.3's unwrap-phase dealiasing of a two-beam sweep changed from one call to the next
#: (by 2 Nyquist velocities, measured on a synthetic field; three and more beams repeat
#: exactly): the block refuses fewer beams rather than give a run numbers it cannot repeat.
MIN_UNWRAP_BEAMS = 3

METHODS = {"region": "VRADH_DEALIASED_REGION", "unwrap_phase": "VRADH_DEALIASED_UNWRAP"}


class VelocityDealias(Block):
    """Dealias the estimated radial velocity of a sweep with Py-ART, scored against the truth's.

    ``region`` is :func:`pyart.correct.dealias_region_based` (regions of similar velocity
    unfolded against their neighbours: it needs the whole sweep), ``unwrap_phase``
    :func:`pyart.correct.dealias_unwrap_phase` (2-D phase unwrapping of the sweep). The ideal
    answer is the truth's velocity itself: dealiasing aims at the unfolded velocity, so the
    error is the dealiased velocity minus the truth's, not taken on the Nyquist circle.
    Py-ART's 2-D unwrapping does not return on this sweep with its censored gates masked
    (Py-ART 2.3.0, seen on 5 beams): ``unwrap_phase`` unwraps with them at 0 m/s and masks
    them again after.
    """

    sweep_level = True

    moments = Input(MOMENTS, doc="estimated moments of the whole sweep")
    scores = Input(SCORES, doc="the scorer's truth on the grid and scored gates")
    dealiased = Output(ALGORITHM_FIELDS, store="moments", doc="the dealiased velocity, scored")

    method = Param(
        "region", type="str", choices=tuple(METHODS), doc="Py-ART's dealiasing algorithm"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        correct = pyart().correct
        moments, scores = inputs["moments"], inputs["scores"]
        need(moments, f"block '{self.name}'", "VRADH", "nyquist_velocity")
        need(scores, f"block '{self.name}'", "truth_VRADH", "scored")
        nyquist = float(np.nanmax(moments["nyquist_velocity"].values))
        radar = make_radar(moments)
        velocity = np.asarray(moments["VRADH"].values, np.float64)
        if self.p["method"] == "region":
            add_field(radar, "velocity", velocity, "m/s")
            out = correct.dealias_region_based(
                radar, vel_field="velocity", nyquist_vel=nyquist, keep_original=False
            )
            dealiased = filled(out)
        else:
            if velocity.shape[0] < MIN_UNWRAP_BEAMS:
                raise ValueError(
                    f"block '{self.name}': method unwrap_phase needs a sweep of at least "
                    f"{MIN_UNWRAP_BEAMS} beams (this one has {velocity.shape[0]}): on fewer, "
                    "Py-ART's 2-D unwrapping answers differently from one call to the next; "
                    "use a wider sector or method: region"
                )
            add_field(radar, "velocity", np.nan_to_num(velocity, nan=0.0), "m/s")
            out = correct.dealias_unwrap_phase(
                radar,
                vel_field="velocity",
                nyquist_vel=nyquist,
                keep_original=False,
                skip_checks=True,
                rays_wrap_around=False,
            )
            dealiased = np.where(np.isfinite(velocity), filled(out), np.nan).astype(np.float32)
        scored, rule = scored_gates(scores)
        name = METHODS[self.p["method"]]
        truth = np.asarray(scores["truth_VRADH"].values, np.float32)
        return {"dealiased": xr.Dataset(product(name, dealiased, truth, scored, rule))}
