"""KDP estimation: Py-ART's estimators on the whole sweep, scored against the same estimator
on the truth's phi_DP."""

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

METHODS = ("maesaka", "vulpiani", "schneebeli")
#: The seed of NumPy's global state while Schneebeli's filter runs (see ``estimate``).
SCHNEEBELI_SEED = 0


class KdpEstimate(Block):
    """Estimate KDP from the estimated phi_DP with one of Py-ART's estimators:
    ``maesaka`` (:func:`pyart.retrieve.kdp_maesaka`, variational, phi_DP monotonic),
    ``vulpiani`` (:func:`pyart.retrieve.kdp_vulpiani`, iterative finite differences) or
    ``schneebeli`` (:func:`pyart.retrieve.kdp_schneebeli`, an ensemble of Kalman filters).

    The ideal answer is the same estimator run on the truth's phi_DP, scaled from the
    truth's frequency to the radar's (KDP goes as the frequency, as the weather channel's
    propagation path scales it): the KDP the radar would estimate from noise-free phi_DP.
    """

    sweep_level = True

    moments = Input(MOMENTS, doc="estimated moments of the whole sweep")
    scores = Input(SCORES, doc="the scorer's truth on the grid and scored gates")
    kdp = Output(ALGORITHM_FIELDS, store="moments", doc="KDP and its error, by the estimator")

    method = Param("vulpiani", type="str", choices=METHODS, doc="Py-ART's KDP estimator")
    frequency_hz = Param(
        None, units="Hz", min=1e9, max=20e9, doc="radar frequency (the estimators' band)"
    )
    truth_frequency_hz = Param(
        2.8e9, units="Hz", min=1e9, max=20e9, doc="frequency of the truth's phi_DP (KLBB: S band)"
    )

    def estimate(self, moments: xr.Dataset, phidp: np.ndarray, band: str) -> np.ndarray:
        """The estimator on ``phidp`` (beam x range, deg) of a sweep on the grid of
        ``moments``."""
        retrieve = pyart().retrieve
        radar = make_radar(moments, self.p["frequency_hz"])
        add_field(radar, "differential_phase", phidp, "degrees")
        common = {"psidp_field": "differential_phase", "kdp_field": "kdp"}
        method = self.p["method"]
        if method == "maesaka":
            kdp = retrieve.kdp_maesaka(radar, **common, phidp_field="phidp_r")[0]
        elif method == "vulpiani":
            kdp = retrieve.kdp_vulpiani(radar, **common, phidp_field="phidp_r", band=band)[0]
        else:
            # Schneebeli's filter pads and fills phi_DP with draws of NumPy's global random
            # state (Py-ART 2.3): seeded here, and the caller's state put back, so that the
            # same sweep gives the same KDP on every call (unseeded, two calls on 6 beams of
            # the bundled storm differed by up to 1.8 deg/km).
            state = np.random.get_state()  # noqa: NPY002 (the state Py-ART draws from)
            np.random.seed(SCHNEEBELI_SEED)  # noqa: NPY002
            try:
                kdp = retrieve.kdp_schneebeli(
                    radar, **common, phidp_field="phidp_r", band=band, parallel=False
                )[0]
            finally:
                np.random.set_state(state)  # noqa: NPY002
        # Where phi_DP has no data the estimate has none either (the estimators fill).
        return np.where(np.isfinite(phidp), filled(kdp), np.nan).astype(np.float32)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        moments, scores = inputs["moments"], inputs["scores"]
        need(moments, f"block '{self.name}'", "PHIDP")
        need(scores, f"block '{self.name}'", "truth_PHIDP", "scored")
        f, f_t = float(self.p["frequency_hz"]), float(self.p["truth_frequency_hz"])
        band = "S" if f < 4e9 else ("C" if f < 8e9 else "X")
        kdp = self.estimate(moments, np.asarray(moments["PHIDP"].values, np.float64), band)
        truth_phidp = np.asarray(scores["truth_PHIDP"].values, np.float64)
        ideal = self.estimate(moments, truth_phidp, band) * np.float32(f / f_t)
        scored, rule = scored_gates(scores)
        name = f"KDP_{self.p['method'].upper()}"
        return {"kdp": xr.Dataset(product(name, kdp, ideal, scored, rule))}
