"""The weather channel's calibration output: the radar constant per beam and polarisation, the
transmit power a run used, stated as a radar engineer states it (per port, or a divided
total; also the score's rule), the path's attenuation along each beam's axis."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from ..angles import circular_difference
from ..signals import POLARIZATIONS, SPEED_OF_LIGHT
from .chunk_setting import ChunkSetting
from .fasttime import RangeModel


def transmit_power(peak_power_w: float, response: xr.Dataset) -> dict[str, Any]:
    """The transmit power convention the run used, for the calibration's attributes.

    Without a ``transmitter.power_divider`` upstream ``peak_power_w`` is each port's peak
    power; with one it is the transmitter's total and each port radiates its share. Either
    way the power radiated at each port is ``peak_power_w`` times the radiated pulse's peak
    |envelope|^2 (the amplifier's output, divided).
    """
    per_port = peak_power_w * float(np.max(np.abs(response["transmitted"].values) ** 2))
    ports = response.attrs.get("power_divider_ports")
    if ports is None:
        text = f"per port (peak_power_w {watts(peak_power_w)} at each port, no divider"
    else:
        loss = float(response.attrs.get("power_divider_loss_db", 0.0))
        text = (
            f"divided total (peak_power_w {watts(peak_power_w)} split {int(ports)} ways "
            f"with {loss:g} dB loss"
        )
    return {
        "transmit_power": f"{text}; radiated peak {watts(per_port)} per port)",
        "transmit_power_per_port_w": per_port,
    }


def watts(w: float) -> str:
    for scale, unit in ((1e6, "MW"), (1e3, "kW")):
        if w >= scale:
            return f"{w / scale:.4g} {unit}"
    return f"{w:.4g} W"


def radar_calibration(
    run: ChunkSetting,
    peak_power_w: float,
    inputs: dict[str, Any],
    ranges: RangeModel,
    path: tuple[xr.Dataset, Any] | None,
    overlay: np.ndarray | None,
) -> xr.Dataset:
    """The radar constant per beam and polarisation (power -> dBZ) with what the
    processors need of the radar, the path's attenuation along each beam's axis and the
    overlaid trips' power."""
    truth, beams = inputs["truth"], inputs["beams"]
    pattern, response = inputs["pattern"], inputs["range_response"]
    omega_cal = pattern["calibration_solid_angle_sr"].values  # beam x polarisation
    constant_db = 10 * np.log10(run.k0 * omega_cal * ranges.total_m)
    calibration = xr.Dataset(
        {
            "radar_constant_db": (
                ("beam", "polarization"),
                constant_db.astype(np.float64),
                {"units": "dB"},
            )
        },
        coords={
            "range": ("range", run.rng_m, {"units": "meters"}),
            "polarization": list(POLARIZATIONS),
        },
        attrs={
            "wavelength_m": run.lam,
            "prt_s": run.prt_t1,
            "dual_polarization": int(run.dual),
            "blind_range_m": float(response.attrs["blind_range_m"]),
            "calibration": str(pattern.attrs["calibration"]),
            "transmission": run.mode,
            "transmit_differential_phase_deg": run.beta,
            "cross_polar_coupling": int(run.coupled),
            **transmit_power(peak_power_w, response),
        },
    )
    if path is not None:
        calibration["path_attenuation_db"] = (
            ("beam", "range", "polarization"),
            axis_attenuation(path[1], truth, beams, run.volume),
            {"units": "dB", "long_name": "two-way path attenuation along the beam's axis"},
        )
    if overlay is not None:
        calibration.attrs["unambiguous_range_m"] = SPEED_OF_LIGHT * run.prt_t1 / 2
        calibration["overlaid_power_ratio_db"] = (
            ("beam", "range"),
            overlay,
            {"units": "dB", "long_name": "power of the other trips over the gate's own"},
        )
    return calibration


def axis_attenuation(path: Any, truth: xr.Dataset, beams: xr.Dataset, volume: bool) -> np.ndarray:
    """Two-way attenuation (dB) of H and V along each beam's axis: the truth radial nearest
    its azimuth (of a volume, in the sweep nearest its elevation); beam x range x pol."""
    az = truth["azimuth"].values
    rows = np.argmin(
        np.abs(circular_difference(az[None, :], beams["azimuth"].values[:, None], 360.0)), axis=1
    )
    if volume:
        sweeps = truth["sweep_elevation"].values
        nearest = np.argmin(np.abs(sweeps[None, :] - beams["elevation"].values[:, None]), axis=1)
        rows = rows + nearest * az.size
    h = path.attenuation_h_db[rows]
    return np.stack([h, h - path.differential_db[rows]], axis=-1)
