"""Rainfall rate from Z and from KDP: Py-ART's power laws on the whole sweep."""

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


class RainRate(Block):
    """Rain rate from the estimated reflectivity (:func:`pyart.retrieve.est_rain_rate_z`,
    R = ``z_alpha`` Z^``z_beta``) and, with ``kdp`` connected, from an estimated KDP
    (:func:`pyart.retrieve.est_rain_rate_kdp`, the coefficients of the radar's band). The
    ideal answer of both is R(Z) from the truth's Z with the same law: the rain rate the
    radar would retrieve from the true reflectivity."""

    sweep_level = True

    moments = Input(MOMENTS, doc="estimated moments of the whole sweep")
    scores = Input(SCORES, doc="the scorer's truth on the grid and scored gates")
    kdp = Input(ALGORITHM_FIELDS, required=False, doc="a KDP estimate (algorithm.kdp), for R(KDP)")
    rain_rate = Output(ALGORITHM_FIELDS, store="moments", doc="R(Z), R(KDP), scored")

    frequency_hz = Param(None, units="Hz", min=1e9, max=20e9, doc="radar frequency (R(KDP))")
    z_alpha = Param(0.0376, min=1e-6, max=10.0, doc="factor of R(Z) (Py-ART's default)")
    z_beta = Param(0.6112, min=0.01, max=2.0, doc="exponent of R(Z) (Py-ART's default)")

    def rate_z(self, moments: xr.Dataset, dbz: np.ndarray) -> np.ndarray:
        radar = make_radar(moments)
        add_field(radar, "reflectivity", dbz, "dBZ")
        rate = pyart().retrieve.est_rain_rate_z(
            radar, alpha=self.p["z_alpha"], beta=self.p["z_beta"], refl_field="reflectivity"
        )
        return filled(rate)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        moments, scores = inputs["moments"], inputs["scores"]
        need(moments, f"block '{self.name}'", "DBZH")
        need(scores, f"block '{self.name}'", "truth_DBZH", "scored")
        scored, rule = scored_gates(scores)
        ideal = self.rate_z(moments, np.asarray(scores["truth_DBZH"].values, np.float64))
        est = self.rate_z(moments, np.asarray(moments["DBZH"].values, np.float64))
        out = product("RATE_Z", est, ideal, scored, rule)
        if "kdp" in inputs:
            kdps = [n for n in inputs["kdp"].data_vars if str(n).startswith("KDP_")]
            if not kdps:
                raise ValueError(f"block '{self.name}': its kdp input holds no KDP_* field")
            radar = make_radar(moments, self.p["frequency_hz"])
            add_field(radar, "kdp", inputs["kdp"][kdps[0]].values, "degrees/km")
            rate = filled(pyart().retrieve.est_rain_rate_kdp(radar, kdp_field="kdp"))
            out.update(product("RATE_KDP", rate, ideal, scored, rule))
        return {"rain_rate": xr.Dataset(out)}
