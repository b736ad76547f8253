"""Receivers: thermal noise at the matched-filter output."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import POLARIMETRIC_FIELDS

from ..signals import (
    BOLTZMANN,
    IQ,
    IQ_CUBE,
    NOISE_POWER,
    POLARIZATIONS,
    RANGE_RESPONSE,
    SIGNAL_POWER,
    T0_K,
    check_pulses,
)


class Receiver(Block):
    """Adds receiver noise: thermal k T0 F B, or a fixed SNR at every gate.

    By default the noise power is k T0 F B (B: the matched filter's noise bandwidth), the same
    at every gate. With ``snr_db`` set, the noise power at each gate is the expected H-channel
    echo power there divided by that SNR (estimator studies); both channels get the same noise
    power, so V's SNR is lower by ZDR. Gates without echo then keep the thermal noise. Noise is
    circular complex Gaussian, independent per gate, pulse and channel, drawn from each beam's
    own random streams (H and V apart; V is skipped when no polarimetric field is asked for).
    Everything is referred to the receiver input: a linear gain scales echo
    and noise alike and changes no moment, so it is left out until saturation and the ADC are
    modelled.
    """

    iq_in = Input(IQ, doc="noise-free echo voltages")
    range_response = Input(RANGE_RESPONSE, doc="matched filter, for its noise bandwidth")
    signal_power = Input(SIGNAL_POWER, required=False, doc="expected echo power (for snr_db)")
    iq = Output(IQ, doc="echo plus noise")
    noise_power = Output(NOISE_POWER, doc="noise power per gate and channel")
    iq_store = Output(IQ_CUBE, store="iq", doc="I/Q cubes to store")

    noise_figure_db = Param(2.7, units="dB", min=0.0, max=30.0, doc="receiver noise figure")
    snr_db = Param(
        None,
        units="dB",
        min=-60.0,
        max=150.0,
        optional=True,
        doc="hold the H-channel SNR at this value at every gate (default: thermal)",
    )

    store_iq = Param(
        True,
        type="bool",
        doc="store this receiver's I/Q with --save-iq (false for a graph's second receiver, "
        "e.g. a split cut's Doppler cut: one store holds one I/Q cube)",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        if params.get("snr_db") is not None and "signal_power" not in connected:
            return [
                (
                    "parameter 'snr_db'",
                    "needs the input 'signal_power' connected (the expected echo power)",
                )
            ]
        return []

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        echo = inputs["iq_in"]
        check_pulses(echo, chunk, self.name)
        bandwidth = float(inputs["range_response"].attrs["noise_bandwidth_hz"])
        thermal = BOLTZMANN * T0_K * 10 ** (self.p["noise_figure_db"] / 10) * bandwidth
        noise = np.full((*echo.shape[:2], 2), thermal)
        if self.p["snr_db"] is not None:
            signal = inputs["signal_power"][..., 0].astype(np.float64)
            fixed = signal / 10 ** (self.p["snr_db"] / 10)
            noise[:] = np.where(signal > 0, fixed, thermal)[..., None]
        # order="K" keeps the echo's memory layout (the weather channel's is channel-major).
        out = echo.copy(order="K")
        scale = np.sqrt(noise / 2).astype(np.float32)
        # H and V noise from their own streams: asking for H only leaves H's numbers unchanged.
        channels = [0, 1] if chunk.wants(*POLARIMETRIC_FIELDS) else [0]
        for i, beam in enumerate(chunk.beams):
            for k in channels:
                w = chunk.rng(int(beam), k).standard_normal((*echo.shape[1:3], 2), np.float32)
                out[i, ..., k] += scale[i, :, None, k] * (w[..., 0] + 1j * w[..., 1])
        result: dict[str, Any] = {"iq": out, "noise_power": noise}
        if chunk.options.get("save_iq") and chunk.expected:
            raise ValueError(
                "--save-iq: the I/Q cube has no pulses to store (the weather channel's "
                "'expected' level draws none); run at 'combined' or a slower level"
            )
        if chunk.options.get("save_iq") and self.p["store_iq"]:
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
