"""Attenuation correction: Py-ART's Z-PHI on the whole sweep, scored against the true Z."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..propagation.rain import coefficients as path_coefficients
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


class ZPhiAttenuation(Block):
    """Correct the estimated reflectivity for rain attenuation with Py-ART's Z-PHI
    (:func:`pyart.correct.calculate_attenuation_zphi`: the path-integrated attenuation from
    the rise of phi_DP, distributed along the ray by the attenuated Z; coefficients of the
    radar's band), below the freezing level. Z-PHI reads the rise of phi_DP along the ray:
    the estimated phi_DP (its system offset, about 75 deg on the bundled storm, and its noise
    included: fed as is, Z-PHI over-corrects by 8 dB there) is first smoothed and made to
    start at 0 by Py-ART's Vulpiani reconstruction (:func:`pyart.retrieve.kdp_vulpiani`),
    as an operational chain processes phi_DP before Z-PHI. The ideal answer is the truth's
    Z, which the weather channel attenuates on the way (propagation on,
    docs/propagation.md): Z-PHI aims at the unattenuated reflectivity.

    ``coefficients``: ``pyart`` takes Py-ART's coefficients of the radar's band (C band:
    A_H = 0.08 KDP); ``propagation`` takes the weather channel's own power laws at
    ``frequency_hz`` (:func:`pasim_blocks.propagation.rain.coefficients`: A_H = alpha KDP,
    A_DP = beta KDP, so c = beta / alpha and d = 1), the Z-PHI consistent with the
    attenuation the simulation applied; Z-PHI's exponent b stays Py-ART's.

    ``min_rhohv``: an operational gate filter. Gates whose estimated rho_hv is lower (noise,
    weak far echo) are left out of the phi_DP reconstruction and of Z-PHI (Py-ART's gate
    filter: each ray's attenuation is then fixed by the phase at its last gates that pass,
    and the corrected Z has no value at the gates left out). Unset, every gate with Z enters
    (the phase Vulpiani's filter integrates at weak far gates over-corrects the squall line,
    docs/algorithms.md)."""

    sweep_level = True

    moments = Input(MOMENTS, doc="estimated moments of the whole sweep")
    scores = Input(SCORES, doc="the scorer's truth on the grid and scored gates")
    corrected = Output(ALGORITHM_FIELDS, store="moments", doc="Z corrected by Z-PHI, scored")

    frequency_hz = Param(
        None, units="Hz", min=1e9, max=20e9, doc="radar frequency (Z-PHI's coefficients)"
    )
    freezing_level_m = Param(
        4000.0, units="m", min=0.0, max=20e3, doc="height of the freezing level above the site"
    )

    coefficients = Param(
        "pyart",
        type="str",
        choices=("pyart", "propagation"),
        doc="Z-PHI's alpha (A_H = alpha KDP): Py-ART's for the band, or the propagation path's",
    )

    min_rhohv = Param(
        None,
        min=0.0,
        max=1.0,
        optional=True,
        doc="gates with a lower estimated rho_hv are left out of phi_DP and Z-PHI (unset: none)",
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        moments, scores = inputs["moments"], inputs["scores"]
        need(moments, f"block '{self.name}'", "DBZH", "PHIDP", "ZDR")
        need(scores, f"block '{self.name}'", "truth_DBZH", "scored")
        psidp = np.asarray(moments["PHIDP"].values, np.float64)
        excluded = None
        if self.p["min_rhohv"] is not None:
            need(moments, f"block '{self.name}' (min_rhohv)", "RHOHV")
            rhohv = np.nan_to_num(np.asarray(moments["RHOHV"].values, np.float64), nan=0.0)
            excluded = rhohv < self.p["min_rhohv"]
            psidp = np.where(excluded, np.nan, psidp)
        radar = make_radar(moments, self.p["frequency_hz"])
        add_field(radar, "reflectivity", moments["DBZH"].values, "dBZ")
        add_field(radar, "psidp", psidp, "degrees")
        add_field(radar, "differential_reflectivity", moments["ZDR"].values, "dB")
        band = (
            "S" if self.p["frequency_hz"] < 4e9 else ("C" if self.p["frequency_hz"] < 8e9 else "X")
        )
        _, phidp = pyart().retrieve.kdp_vulpiani(
            radar, psidp_field="psidp", kdp_field="kdp", phidp_field="phidp", band=band
        )
        measured = np.isfinite(psidp)
        add_field(radar, "differential_phase", np.where(measured, filled(phidp), np.nan))
        gates = None
        if excluded is not None:
            gates = pyart().filters.GateFilter(radar)
            gates.exclude_gates(excluded | np.ma.getmaskarray(radar.fields["reflectivity"]["data"]))
        laws: dict[str, float] = {}
        if self.p["coefficients"] == "propagation":
            alpha, _, beta, _ = path_coefficients(float(self.p["frequency_hz"]))
            # Z-PHI's exponent b of the band, from Py-ART's own table (it takes all four
            # coefficients or none).
            _, b, _, _ = pyart().correct.attenuation._get_param_attzphi(
                float(self.p["frequency_hz"])
            )
            laws = {"a_coef": alpha, "beta": b, "c": beta / alpha, "d": 1.0}
        out = pyart().correct.calculate_attenuation_zphi(
            radar,
            **laws,
            fzl=self.p["freezing_level_m"],
            temp_ref="fixed_fzl",
            refl_field="reflectivity",
            phidp_field="differential_phase",
            zdr_field="differential_reflectivity",
            gatefilter=gates,
        )
        corrected = filled(out[2])
        scored, rule = scored_gates(scores)
        truth = np.asarray(scores["truth_DBZH"].values, np.float32)
        return {"corrected": xr.Dataset(product("DBZH_ZPHI", corrected, truth, scored, rule))}
