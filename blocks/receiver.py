"""Receivers: thermal noise at the matched-filter output."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from .signals import BOLTZMANN, IQ, IQ_CUBE, NOISE_POWER, POLARIZATIONS, RANGE_RESPONSE, T0_K


class Receiver(Block):
    """Adds thermal noise k T0 F B (B: the matched filter's noise bandwidth).

    Everything is referred to the receiver input: a linear gain scales echo and noise alike and
    changes no moment, so it is left out until the receiver models saturation and the ADC.

    Both channels have the same noise figure and bandwidth. Noise is circular complex
    Gaussian, independent per gate, pulse and channel, from each beam's own random stream.

    Inputs
    ------
    iq : iq
        Noise-free echo voltages.
    range_response : range_response
        Gives the noise bandwidth of the matched filter.

    Outputs
    -------
    iq : iq
        Echo plus noise.
    noise_power : noise_power
        Noise power per channel at the output (W).
    iq_store : iq_cube
        H and V I/Q cubes for the output volume (only when the run saves I/Q).
    """

    iq_in = Input(IQ, doc="noise-free echo voltages")
    range_response = Input(RANGE_RESPONSE, doc="matched filter, for its noise bandwidth")
    iq = Output(IQ, doc="echo plus noise")
    noise_power = Output(NOISE_POWER, doc="noise power per channel")
    iq_store = Output(IQ_CUBE, store="iq", doc="I/Q cubes to store")

    noise_figure_db = Param(2.7, units="dB", min=0.0, max=30.0, doc="receiver noise figure")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        echo = inputs["iq_in"]
        bandwidth = float(inputs["range_response"].attrs["noise_bandwidth_hz"])
        noise = BOLTZMANN * T0_K * 10 ** (self.p["noise_figure_db"] / 10) * bandwidth
        out = np.empty_like(echo)
        scale = np.float32(np.sqrt(noise / 2))
        for i, beam in enumerate(chunk.beams):
            w = chunk.rng(int(beam)).standard_normal((*echo.shape[1:], 2), dtype=np.float32)
            out[i] = echo[i] + scale * (w[..., 0] + 1j * w[..., 1])
        result: dict[str, Any] = {"iq": out, "noise_power": np.full(2, noise)}
        if chunk.options.get("save_iq"):
            dims = ("beam", "range", "pulse")
            result["iq_store"] = xr.Dataset(
                {
                    f"IQ_{p}": (
                        dims,
                        out[..., k],
                        {"units": "sqrt(W)", "long_name": f"{p} channel I/Q"},
                    )
                    for k, p in enumerate(POLARIZATIONS)
                }
            )
        return result
