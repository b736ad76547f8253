"""The path from the radar to each truth cell and back, at the simulated radar's frequency.

:func:`propagate` returns the truth as the simulated radar receives it: each truth radial is a
ray from the radar (the simulated radar stands at the truth radar's site), and along it, from
the radar to each cell's centre (half the cell's own gate included),

- DBZH loses the two-way path-integrated attenuation PIA_H = 2 int (A_H + gas) dr,
- ZDR loses the two-way differential attenuation 2 int A_DP dr (gases attenuate H and V
  alike),
- PHIDP gains 2 int (KDP(f) - KDP(f_t)) dr: the truth's own PHIDP (its system offset,
  backscatter phase and noise kept) plus the propagation phase the new frequency adds,

with KDP, A_H and A_DP from :mod:`.rain` and the gases from :mod:`.gas`. The weather channel
weights these cells through the two-way pattern as it weights any cell, so a beam sees the
attenuation of every radial its pattern reaches, not only that of its axis. The truth
itself (what the scorer compares with) stays the unattenuated weather: NEXRAD's reflectivity
is corrected for the gases, and its own S-band rain attenuation (about a quarter of C
band's) is left in it, the approximation of taking the truth as the weather. Reflectivity is
not scaled with frequency (Rayleigh: Z is the same at S, C and X band) and the backscatter
differential phase of resonant drops at C and X band is not added.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Param, RunNote

from .gas import two_way_gas_db
from .rain import COVERED_HZ, band, coefficients, kdp_from_phidp

#: The weather channel's propagation switch.
SWITCHES = ("auto", "on", "off")


class PropagationParams:
    """The weather channel's propagation parameters, as a mixin: a Block subclass inherits
    them (with ``frequency_hz`` and ``truth_frequency_hz`` from the channel)."""

    propagation = Param(
        "auto",
        type="str",
        choices=SWITCHES,
        doc="attenuation and differential phase of the path at frequency_hz "
        "(pasim_blocks.propagation): auto (on when frequency_hz is in another band than "
        "truth_frequency_hz, off in the same band), on, off",
    )
    gaseous_attenuation = Param(
        True,
        type="bool",
        doc="with propagation on, add the two-way gaseous attenuation (ITU-R P.676 "
        "simplified, along the 4/3-earth beam)",
    )
    kdp_window_m = Param(
        5000.0,
        units="m",
        min=500.0,
        max=50000.0,
        doc="range over which the truth's PHIDP is differentiated to give KDP",
    )
    kdp_min_rhohv = Param(
        0.9,
        min=0.0,
        max=1.0,
        doc="truth gates with a lower rho_hv do not enter the KDP fit (clutter, noise)",
    )


def propagation_on(params: dict[str, Any]) -> bool:
    """Whether the path is applied: forced on or off, or (auto) when the radar's band is not
    the truth's."""
    switch = params.get("propagation", "auto")
    if switch != "auto":
        return bool(switch == "on")
    return band(float(params["frequency_hz"])) != band(float(params["truth_frequency_hz"]))


def propagation_problems(params: dict[str, Any]) -> list[tuple[str, str]]:
    """Validation: a path to apply needs coefficients at the radar's frequency."""
    full = {"frequency_hz": 2.8e9, "truth_frequency_hz": 2.8e9, **params}
    lo, hi = COVERED_HZ
    f = float(full["frequency_hz"])
    if propagation_on(full) and not lo <= f <= hi:
        return [
            (
                "parameter 'propagation'",
                f"{full.get('propagation', 'auto')} at frequency_hz {f:g}: rain attenuation "
                f"coefficients exist from {lo:g} to {hi:g} Hz only (set propagation off)",
            )
        ]
    return []


@dataclass(frozen=True)
class Path:
    """Two-way path integrals on the truth's radial x gate grid (dB, dB, deg) and KDP."""

    attenuation_h_db: np.ndarray
    differential_db: np.ndarray
    extra_phase_deg: np.ndarray
    kdp_deg_km: np.ndarray


def path_integrals(truth: xr.Dataset, elevation_deg: np.ndarray, params: dict[str, Any]) -> Path:
    """The two-way path integrals of every radial of ``truth`` (radial x gate; ``elevation_deg``
    per radial, for the gases' heights)."""
    f, f_t = float(params["frequency_hz"]), float(params["truth_frequency_hz"])
    dbz = truth["DBZH"].values
    step_km = float(truth.attrs["gate_width_m"]) / 1e3
    if "PHIDP" in truth:
        kdp_t = kdp_from_phidp(
            truth["PHIDP"].values.astype(np.float64),
            dbz,
            truth["RHOHV"].values if "RHOHV" in truth else None,
            float(truth.attrs["gate_width_m"]),
            float(params["kdp_window_m"]),
            float(params["kdp_min_rhohv"]),
        )
    else:
        kdp_t = np.zeros(dbz.shape)
    kdp = kdp_t * (f / f_t)
    alpha, b, beta, d = coefficients(f)

    def two_way(specific: np.ndarray) -> np.ndarray:
        # From the radar to each cell's centre: every earlier gate and half of its own.
        step = specific * step_km
        return 2 * (np.cumsum(step, axis=1) - step / 2)

    a_h = two_way(alpha * kdp**b)
    a_dp = two_way(beta * kdp**d)
    extra = two_way(kdp - kdp_t)
    if params.get("gaseous_attenuation", True):
        rng = truth["range"].values
        altitude = float(truth.attrs.get("altitude", 0.0))
        for el in np.unique(elevation_deg):
            rows = elevation_deg == el
            a_h[rows] += two_way_gas_db(f, rng, float(el), altitude)[None, :]
    return Path(a_h, a_dp, extra, kdp)


def propagate(
    truth: xr.Dataset, elevation_deg: np.ndarray, params: dict[str, Any]
) -> tuple[xr.Dataset, Path]:
    """The truth as received through the path (module docstring), and the path."""
    path = path_integrals(truth, elevation_deg, params)
    out = truth.copy()
    changes = {"DBZH": -path.attenuation_h_db, "ZDR": -path.differential_db}
    changes["PHIDP"] = path.extra_phase_deg
    for name, change in changes.items():
        if name in truth:
            var = truth[name]
            out[name] = (var.dims, (var.values + change).astype(var.dtype), var.attrs)
    return out, path


def note(params: dict[str, Any]) -> None:
    """Say once in the run's output that the path is applied (the command line prints each
    note once)."""
    f, f_t = float(params["frequency_hz"]), float(params["truth_frequency_hz"])
    alpha, _, beta, _ = coefficients(f)
    gas = " and gaseous" if params.get("gaseous_attenuation", True) else ""
    warnings.warn(
        f"weather: propagation on at {f / 1e9:g} GHz (truth at {f_t / 1e9:g} GHz): rain{gas} "
        f"attenuation applied to the echo (A_H = {alpha:.4g} KDP, A_DP = {beta:.4g} KDP, KDP "
        f"scaled by {f / f_t:.3g}); the truth stays unattenuated",
        RunNote,
        stacklevel=2,
    )
