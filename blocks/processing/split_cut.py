"""A NEXRAD split cut merged: surveillance reflectivity, Doppler velocity range-unfolded.

The legacy WSR-88D range unfolding (Doviak and Zrnic 1993, section 7.4.2; the "TOVER"
threshold of the RDA): the Doppler cut's short PRT folds the echoes of r + k r_a onto each
gate r (r_a = c T_D / 2). The long-PRT surveillance cut, unambiguous over the whole range,
gives each candidate range its echo power, P_k ~ Z(r_k) / r_k^2. Where the strongest
candidate exceeds the sum of the others by ``overlay_threshold_db`` (5 dB, the WSR-88D's
TOVER), the Doppler cut's velocity and width belong to that range; elsewhere they are
range-folded and not reported (NaN). Reflectivity and the polarimetric moments are the
surveillance cut's; the Nyquist velocity is the Doppler cut's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import MOMENT_FIELDS

from ..signals import BEAMS, CALIBRATION, IQ, MOMENTS, NOISE_POWER, SPEED_OF_LIGHT
from .output import Censoring
from .pulse_pair import PulsePairProcessor


def unfold(
    surveillance_dbz: np.ndarray,
    rng_m: np.ndarray,
    r_a_m: float,
    threshold_db: float,
) -> tuple[np.ndarray, np.ndarray]:
    """For each Doppler gate (beam x gate nearer than r_a): the gate its echo is assigned to
    (-1: range-folded or no echo), from the surveillance reflectivity (beam x gate, dBZ,
    NaN where none) on the uniform range grid ``rng_m``."""
    gate_m = float(rng_m[1] - rng_m[0])
    n_a = round(r_a_m / gate_m)
    n_g = surveillance_dbz.shape[1]
    near = np.flatnonzero(rng_m < r_a_m)
    trips = int(np.ceil(n_g / n_a)) + 1
    cand = near[:, None] + n_a * np.arange(trips)[None, :]  # gate x trip
    inside = cand < n_g
    idx = np.minimum(cand, n_g - 1)
    with np.errstate(over="ignore"):
        power = np.where(
            inside[None] & np.isfinite(surveillance_dbz[:, idx]),
            10 ** (np.nan_to_num(surveillance_dbz[:, idx], nan=-999.0) / 10)
            / rng_m[idx][None] ** 2,
            0.0,
        )  # beam x gate x trip
    best = np.argmax(power, axis=-1)
    top = np.take_along_axis(power, best[..., None], axis=-1)[..., 0]
    rest = power.sum(axis=-1) - top
    with np.errstate(divide="ignore", invalid="ignore"):
        clear = (top > 0) & ~(10 * np.log10(top / rest) < threshold_db)
    target = np.where(clear, near[None, :] + n_a * best, -1)
    return near, target


class SplitCutProcessor(Censoring, Block):
    """A split cut's two dwells per beam, each pulse-pair processed, merged by the legacy
    range unfolding (see :mod:`pasim_blocks.processing.split_cut`).

    The surveillance inputs come from the scan's own chain (long PRT), the ``doppler_``
    inputs from a second weather channel and receiver fed by ``scan.doppler_cut``. Both are
    estimated and censored as ``processor.pulse_pair`` does; DBZH and the polarimetric
    moments are the surveillance cut's, VRADH and WRADH the Doppler cut's, unfolded.
    """

    iq = Input(IQ, doc="surveillance cut: received I/Q")
    noise_power = Input(NOISE_POWER, doc="surveillance cut: noise power")
    calibration = Input(CALIBRATION, doc="surveillance cut: radar constant and gate ranges")
    beams = Input(BEAMS, doc="surveillance cut: beams")
    doppler_iq = Input(IQ, doc="Doppler cut: received I/Q")
    doppler_noise_power = Input(NOISE_POWER, doc="Doppler cut: noise power")
    doppler_calibration = Input(CALIBRATION, doc="Doppler cut: radar constant")
    doppler_beams = Input(BEAMS, doc="Doppler cut: beams (its PRT)")
    moments = Output(MOMENTS, store="moments", doc="merged moments", fields=MOMENT_FIELDS)

    overlay_threshold_db = Param(
        5.0,
        units="dB",
        min=0.0,
        max=60.0,
        doc="the strongest trip must exceed the others by this to be unfolded (TOVER)",
    )

    def setup(self) -> None:
        keys = (
            "snr_threshold_reflectivity_db",
            "snr_threshold_doppler_db",
            "snr_threshold_polarimetric_db",
        )
        self._pp = PulsePairProcessor(name=self.name, **{k: self.p[k] for k in keys})

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        surv = self._pp.process(
            {k: inputs[k] for k in ("iq", "noise_power", "calibration", "beams")}, chunk
        )["moments"]
        dop = self._pp.process(
            {k: inputs[f"doppler_{k}"] for k in ("iq", "noise_power", "calibration", "beams")},
            chunk,
        )["moments"]
        prt = float(inputs["doppler_beams"]["prt"].values[0])
        rng = surv["range"].values
        if dop.sizes["range"] != rng.size or rng.size < 2:
            raise ValueError(
                f"the cuts' range grids differ ({rng.size} and {dop.sizes['range']} gates)"
            )
        if "DBZH" not in surv:
            raise ValueError("range unfolding needs the surveillance cut's DBZH")
        r_a = SPEED_OF_LIGHT * prt / 2
        out = surv.copy()
        near, target = unfold(surv["DBZH"].values, rng, r_a, self.p["overlay_threshold_db"])
        for name in ("VRADH", "WRADH"):
            if name not in dop:
                continue
            merged = np.full(surv["DBZH"].shape, np.nan, np.float32)
            values = dop[name].values[:, near]
            for b in range(merged.shape[0]):
                ok = target[b] >= 0
                merged[b, target[b, ok]] = values[b, ok]
            out[name] = (("beam", "range"), merged, dict(dop[name].attrs))
        out["nyquist_velocity"] = dop["nyquist_velocity"]
        out.attrs["split_cut"] = (
            f"DBZH and polarimetry from the surveillance cut; VRADH, WRADH from the Doppler "
            f"cut (PRT {prt:g} s), range-unfolded by the surveillance power (TOVER "
            f"{self.p['overlay_threshold_db']:g} dB)"
        )
        return {"moments": out}
