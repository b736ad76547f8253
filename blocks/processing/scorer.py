"""Scoring: estimated moments against the truth, judged by the NEXRAD requirements."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import MOMENT_UNITS, cf_attributes

from ..angles import circular_difference, nearest_radial
from ..signals import BEAMS, CALIBRATION, MOMENTS, NOISE_POWER, SCORES, SIGNAL_POWER, TRUTH
from ..truth.volume import beam_truth, is_volume

#: NEXRAD data-quality requirements (paper Table 3): bias, standard deviation, units.
REQUIREMENTS = {
    "DBZH": (1.0, 1.0),
    "VRADH": (1.0, 1.0),
    "WRADH": (1.0, 1.0),
    "ZDR": (0.1, 0.2),
    "RHOHV": (0.005, 0.01),
    "PHIDP": (1.0, 2.0),
}


class NexradScorer(Block):
    """Errors of each moment against the raw truth gate each beam is centred on (with a volume
    truth, at the beam's own elevation, as the truth interpolates between its sweeps).

    A gate is scored where the truth reflectivity is at least ``min_reflectivity_dbz`` and the
    expected SNR at least ``min_snr_db`` (so runs and systems are comparable), and where both
    the estimate and the truth of that moment exist. Velocity is differenced on the circle of
    the simulated radar's Nyquist interval, phi_DP on 360 deg (180 deg when the moments say it
    is measured modulo 180, as alternate transmission does). ``pasim score`` reduces the
    errors to bias and standard deviation and judges them against paper Table 3.
    """

    moments = Input(MOMENTS, doc="estimated moments")
    truth = Input(TRUTH, doc="truth sweep")
    signal_power = Input(SIGNAL_POWER, doc="expected echo power")
    noise_power = Input(NOISE_POWER, doc="noise power per channel")
    beams = Input(BEAMS, doc="beam geometry")
    calibration = Input(
        CALIBRATION,
        required=False,
        doc="the weather channel's calibration: with range folding, the other trips' power",
    )
    scores = Output(SCORES, store="moments", doc="truth on the grid, SNR and errors")

    min_reflectivity_dbz = Param(
        10.0,
        units="dBZ",
        min=-100.0,
        max=100.0,
        doc="score gates with truth reflectivity at least this",
    )
    min_snr_db = Param(
        10.0, units="dB", min=-100.0, max=100.0, doc="score gates with expected SNR at least this"
    )

    max_overlay_db = Param(
        -20.0,
        units="dB",
        min=-100.0,
        max=100.0,
        doc="gates where the other trips' expected power over the gate's own exceeds this are "
        "flagged overlaid and scored apart (not in the scores)",
    )

    def setup(self) -> None:
        self._cf = cf_attributes()

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        cf = self._cf

        est, truth, beams = inputs["moments"], inputs["truth"], inputs["beams"]
        radials = truth["azimuth"].values
        az = beams["azimuth"].values
        nearest = nearest_radial(az, radials)
        with np.errstate(divide="ignore"):
            snr = 10 * np.log10(inputs["signal_power"][..., 0] / inputs["noise_power"][..., 0])
        if is_volume(truth):
            # A volume truth: each beam against the truth at its own radial and elevation.
            ref = beam_truth(truth, az, beams["elevation"].values)
            between = truth.attrs.get("elevation_interpolation", "linear")
            truth_is = f"the radial nearest each beam at its elevation ({between} between sweeps)"
        else:
            ref = truth.isel(radial=nearest)
            truth_is = "the raw radial nearest each beam"
        n_est = est.sizes["range"]
        dbz_t = ref["DBZH"].values[:, :n_est]
        blind = float(est.attrs["blind_range_m"])
        with np.errstate(invalid="ignore"):
            scored = (
                (dbz_t >= self.p["min_reflectivity_dbz"])
                & (snr >= self.p["min_snr_db"])
                & (est["range"].values >= blind)[None, :]
            )
        cal = inputs.get("calibration")
        overlaid = None
        if cal is not None and "overlaid_power_ratio_db" in cal:
            ratio = cal["overlaid_power_ratio_db"].values[:, :n_est]
            with np.errstate(invalid="ignore"):
                overlaid = scored & (ratio > self.p["max_overlay_db"])
            scored &= ~overlaid
        rule = (
            f"truth DBZH >= {self.p['min_reflectivity_dbz']:g} dBZ and expected SNRH >= "
            f"{self.p['min_snr_db']:g} dB, beyond the blind range ({blind:g} m); truth = "
            f"{truth_is}; calibration: {est.attrs['calibration']}"
        )
        if "transmit_power" in est.attrs:
            rule += f"; transmit power: {est.attrs['transmit_power']}"
        if est.attrs.get("transmission") == "ahv":
            rule += (
                "; transmission: ahv (velocity and phi_DP scored on its own circles, +-v_a and "
                "180 deg)"
            )
        dims = ("beam", "range")
        scored_attrs = {
            "pasim_role": "scored",
            "long_name": "gate meets the scoring rule",
            "scored": rule,
        }
        # Moments estimated that the truth does not hold (a reflectivity-only file, a
        # single-polarisation truth): not scored, and named so, never silently absent.
        no_truth = [n for n in REQUIREMENTS if n in est and n not in ref]
        if no_truth:
            scored_attrs["no_truth"] = " ".join(no_truth)
        out = xr.Dataset(
            {
                "SNRH": (
                    dims,
                    snr.astype(np.float32),
                    {
                        **cf.var("SNRH"),
                        "units": "dB",
                        "long_name": "expected signal-to-noise ratio H (noise-free echo power)",
                    },
                ),
                "scored": (dims, scored.astype(np.int8), scored_attrs),
            }
        )
        if overlaid is not None:
            out["overlaid"] = (
                dims,
                overlaid.astype(np.int8),
                {
                    "pasim_role": "excluded",
                    "long_name": "gate meets the rule but another trip overlays it",
                    "excluded": f"overlaid by other trips above {self.p['max_overlay_db']:g} dB "
                    "of the gate's own echo (range folding)",
                },
            )
        nyquist = est["nyquist_velocity"].values[:, None]
        # Alternate transmission measures phi_DP modulo 180 deg (as velocity modulo its
        # Nyquist interval): it is scored on that circle.
        phidp_period = float(est.attrs.get("phidp_period_deg", 360.0))
        for name, (req_b, req_s) in REQUIREMENTS.items():
            units = MOMENT_UNITS[name]
            if name not in est or name not in ref:
                continue
            t = ref[name].values[:, :n_est].astype(np.float64)
            e = est[name].values.astype(np.float64)
            if name == "VRADH":
                err = circular_difference(e, t, 2 * nyquist)
            elif name == "PHIDP":
                err = circular_difference(e, t, phidp_period)
            else:
                err = e - t
            err = np.where(scored & np.isfinite(err), err, np.nan)
            # Circular moments say their period, so differences of errors can be wrapped too.
            period = {"VRADH": float(2 * nyquist.flat[0]), "PHIDP": phidp_period}.get(name)
            out[f"truth_{name}"] = (
                dims,
                t.astype(np.float32),
                {**cf.var(name), "units": units, "source": "truth"},
            )
            out[f"error_{name}"] = (
                dims,
                err.astype(np.float32),
                {
                    "pasim_role": "error",
                    "moment": name,
                    "truth_variable": f"truth_{name}",
                    "units": units,
                    "requirement_bias": req_b,
                    "requirement_std": req_s,
                    "scored": rule,
                    "long_name": f"{name} estimate minus truth",
                    **({"period": period} if period else {}),
                },
            )
        return {"scores": out}
