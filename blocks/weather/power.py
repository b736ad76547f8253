"""The transmit power a run used, stated as a radar engineer states it (per port, or a
divided total), for the calibration's attributes and the score's rule."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr


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
