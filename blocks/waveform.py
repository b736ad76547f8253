"""Transmit waveforms: the complex envelope of one pulse, sampled."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param

from .signals import PULSE


def pulse_dataset(envelope: np.ndarray, sample_rate_hz: float, **attrs: Any) -> xr.Dataset:
    """Wrap a complex envelope (peak amplitude 1 = peak power) as a pulse signal."""
    n = envelope.size
    return xr.Dataset(
        {"envelope": ("sample", envelope.astype(np.complex128), {"units": "1"})},
        coords={"time": ("sample", np.arange(n) / sample_rate_hz, {"units": "s"})},
        attrs={"sample_rate_hz": float(sample_rate_hz), **attrs},
    )


class RectangularPulse(Block):
    """A rectangular pulse of constant amplitude and phase (no pulse compression)."""

    pulse = Output(PULSE, doc="transmit envelope, peak amplitude 1")

    width_s = Param(1.6e-6, units="s", min=1e-8, max=1e-3, doc="pulse width")
    sample_rate_hz = Param(
        20e6,
        units="Hz",
        min=1e5,
        max=1e10,
        doc="envelope sample rate (sets the range resolution of weighting)",
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        n = max(1, round(self.p["width_s"] * self.p["sample_rate_hz"]))
        return {
            "pulse": pulse_dataset(
                np.ones(n, complex),
                self.p["sample_rate_hz"],
                waveform="rectangular",
                width_s=self.p["width_s"],
            )
        }
