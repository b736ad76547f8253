"""The processors' common last step: calibrated, censored moments as a CfRadial Dataset.

Every processor (pulse-pair, spectral, staggered PRT, SZ-2) estimates noise-corrected powers
and moments its own way and hands them here: reflectivity from the H power and the radar
constant, ZDR corrected for the H-V constant difference, censoring by estimated SNR and the
blind range, the Nyquist velocity the moments were measured on.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Chunk, Param
from pasim_graph.fm301 import MOMENT_UNITS, POLARIMETRIC_FIELDS, cf_attributes


class Censoring:
    """The three SNR thresholds of a processor (defaults: those the KLBB volume was censored
    at), as a mixin: a Block subclass inherits the declarations."""

    snr_threshold_reflectivity_db = Param(
        2.0,
        units="dB",
        min=-100.0,
        max=100.0,
        optional=True,
        doc="censor DBZH where the estimated SNR is below (null: never)",
    )
    snr_threshold_doppler_db = Param(
        3.5,
        units="dB",
        min=-100.0,
        max=100.0,
        optional=True,
        doc="censor VRADH and WRADH where the estimated SNR is below (null: never)",
    )
    snr_threshold_polarimetric_db = Param(
        2.0,
        units="dB",
        min=-100.0,
        max=100.0,
        optional=True,
        doc="censor ZDR, RHOHV and PHIDP where the estimated SNR is below (null: never)",
    )


def thresholds(p: dict[str, Any]) -> dict[str, float]:
    """Censoring threshold (dB) per moment from the block's parameters (None: never)."""
    t = {
        "DBZH": p["snr_threshold_reflectivity_db"],
        "VRADH": p["snr_threshold_doppler_db"],
        "WRADH": p["snr_threshold_doppler_db"],
    }
    t |= dict.fromkeys(POLARIMETRIC_FIELDS, p["snr_threshold_polarimetric_db"])
    return {k: -np.inf if v is None else float(v) for k, v in t.items()}


def censoring_attrs(threshold_db: float) -> dict[str, Any]:
    if not np.isfinite(threshold_db):
        return {"censoring": "none"}
    return {
        "censoring": f"estimated SNR below {threshold_db:g} dB",
        "snr_threshold_db": threshold_db,
    }


def moments_dataset(
    est: dict[str, np.ndarray],
    noise_h: np.ndarray,
    cal: xr.Dataset,
    chunk: Chunk,
    threshold_db: dict[str, float],
    nyquist_ms: float,
    attrs: dict[str, Any],
    snr_power: np.ndarray | None = None,
    beyond_unambiguous: bool = False,
) -> xr.Dataset:
    """The MOMENTS Dataset from noise-corrected estimates (``S_H`` W, ``ZDR`` dB uncorrected
    for the V constant, ``RHOHV``, ``PHIDP`` deg, ``VRADH``, ``WRADH`` m/s; what is there).

    Censoring uses the estimated SNR of ``snr_power`` (default ``S_H``) over ``noise_h``.
    Gates at or beyond the calibration's unambiguous range (range folding) are masked unless
    ``beyond_unambiguous`` (a processor that recovers the far trips).
    ``attrs`` are added to the Dataset's (``transmission``, ``phidp_period_deg``, ...).
    """
    cf = cf_attributes()
    rng = cal["range"].values
    const = cal["radar_constant_db"].values  # beam x polarisation
    with np.errstate(divide="ignore", invalid="ignore"):
        dbz = (
            10 * np.log10(np.where(est["S_H"] > 0, est["S_H"], np.nan))
            + 20 * np.log10(rng)[None, :]
            - const[:, :1]
        )
    fields = {"DBZH": dbz}
    if "ZDR" in est:
        # The V radar constant may differ from H (patterns); ZDR is corrected for that.
        fields["ZDR"] = est["ZDR"] - (const[:, :1] - const[:, 1:])
    fields |= {k: est[k] for k in ("RHOHV", "PHIDP", "VRADH", "WRADH") if k in est}
    fields = {k: v for k, v in fields.items() if chunk.wants(k)}
    # Censoring as an operational radar does: a moment is reported only where the
    # estimated SNR (noise-corrected H power over the noise) reaches its threshold, and
    # nowhere inside the blind range (the receiver is off while the pulse goes out).
    s = est["S_H"] if snr_power is None else snr_power
    with np.errstate(divide="ignore", invalid="ignore"):
        snr_db = 10 * np.log10(np.where(s > 0, s, np.nan) / noise_h)
    blind = float(cal.attrs["blind_range_m"])
    visible = rng[None, :] >= blind
    if "unambiguous_range_m" in cal.attrs and not beyond_unambiguous:
        # No sample is taken at or beyond c T / 2 (the next pulse has gone out).
        visible = visible & (rng[None, :] < float(cal.attrs["unambiguous_range_m"]))
    ds = xr.Dataset(
        {
            k: (
                ("beam", "range"),
                np.where(visible & ~(snr_db < threshold_db[k]), v, np.nan).astype(np.float32),
                cf.var(k) | {"units": MOMENT_UNITS[k]} | censoring_attrs(threshold_db[k]),
            )
            for k, v in fields.items()
        },
        coords={"range": ("range", rng, dict(cf.range))},
        attrs={
            "blind_range_m": blind,
            "calibration": str(cal.attrs["calibration"]),
            **(
                {"transmit_power": cal.attrs["transmit_power"]}
                if "transmit_power" in cal.attrs
                else {}
            ),
            **attrs,
        },
    )
    ds["nyquist_velocity"] = (
        "beam",
        np.full(const.shape[0], nyquist_ms),
        dict(cf.nyquist_velocity),
    )
    return ds
