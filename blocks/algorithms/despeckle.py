"""A gate filter: Py-ART's despeckle on the whole sweep's reflectivity."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import MOMENTS, SCORES
from .sweep_radar import ALGORITHM_FIELDS, add_field, make_radar, need, product, pyart, scored_gates


class Despeckle(Block):
    """Remove speckles from the estimated reflectivity with Py-ART's gate filter
    (:func:`pyart.correct.despeckle_field`: connected regions of fewer than ``size_gates``
    gates with data are excluded). The ideal answer is the same filter on the truth's Z."""

    sweep_level = True

    moments = Input(MOMENTS, doc="estimated moments of the whole sweep")
    scores = Input(SCORES, doc="the scorer's truth on the grid and scored gates")
    despeckled = Output(ALGORITHM_FIELDS, store="moments", doc="Z without speckles, scored")

    size_gates = Param(
        10, type="int", min=1, max=100_000, doc="regions smaller than this are speckles"
    )

    def despeckle(self, moments: xr.Dataset, dbz: np.ndarray) -> np.ndarray:
        """``dbz`` (beam x range) with its speckles set to NaN."""
        radar = make_radar(moments)
        add_field(radar, "reflectivity", dbz, "dBZ")
        gates = pyart().correct.despeckle_field(radar, "reflectivity", size=self.p["size_gates"])
        return np.where(gates.gate_excluded, np.nan, dbz).astype(np.float32)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        moments, scores = inputs["moments"], inputs["scores"]
        need(moments, f"block '{self.name}'", "DBZH")
        need(scores, f"block '{self.name}'", "truth_DBZH", "scored")
        est = self.despeckle(moments, np.asarray(moments["DBZH"].values, np.float64))
        ideal = self.despeckle(moments, np.asarray(scores["truth_DBZH"].values, np.float64))
        scored, rule = scored_gates(scores)
        return {"despeckled": xr.Dataset(product("DBZH_DESPECKLED", est, ideal, scored, rule))}
