"""An analogue-to-digital converter: quantisation of I and Q, clipping of the received sum."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import DATASET, Attr, Block, Chunk, Input, Output, Param, PortType, Schema, Var

from ..signals import IQ, NOISE_POWER, check_pulses

#: What the ADC reports per gate: how many of its samples hit a rail.
ADC_CLIPPING = PortType(
    "adc_clipping",
    DATASET,
    ("beam", "range"),
    "count",
    Schema(
        {
            "ADC_CLIPPED": Var(
                "int32",
                ("beam", "range"),
                "count",
                "samples (pulses x channels) whose I or Q hit the ADC's rails",
            )
        },
        {
            "clipped_samples": Attr("int", "clipped samples in this chunk of beams"),
            "clipped_gates": Attr("int", "gates of this chunk with at least one clipped sample"),
            "adc_step_w": Attr("float", "quantisation step squared, receiver-input referred (W)"),
        },
    ),
)


def quantise(x: np.ndarray, step: float, bits: int) -> tuple[np.ndarray, np.ndarray]:
    """Mid-rise uniform quantiser of ``2**bits`` levels on one rail, and where it clipped.

    The levels are (k + 1/2) step for k = -2^(bits-1) .. 2^(bits-1) - 1; the rails are at
    +-2^(bits-1) step, and a value beyond a rail comes out as the outermost level.
    """
    half = 2 ** (bits - 1)
    k = np.floor(x / step)
    clipped = (k >= half) | (k < -half)
    return (np.clip(k, -half, half - 1) + 0.5) * step, clipped


class ADC(Block):
    """Quantises I and Q with ``bits`` bits and clips them at the ADC's full scale.

    The chain's voltages are referred to the receiver input (|v|^2 in W). The ADC sees them
    times the receiver gain ``gain_db``; a rail (I or Q) clips at +-sqrt(P_fs), P_fs the full
    scale ``full_scale_dbm`` (the power of a complex tone whose I and Q just reach the rails),
    and the step is 2 sqrt(P_fs) / 2^bits (a mid-rise quantiser). The output is referred back to
    the receiver input, so the calibration is unchanged. Each gate's sample is the receiver's
    output at that instant: the sum of every echo the range response puts there plus noise,
    so a strong core clips on the drawn sum, pulse by pulse, not on its expected power. The
    sample stands for the ADC's sample at the gate (one sample per gate; the ADC is placed
    after the receive filter, before the pulse-pair processor). Quantisation noise is step^2/12
    per rail (uniform, when the signal spans several steps): with ``noise_power_in`` connected
    the noise power handed on adds step^2/6 (referred to the input), as a receiver that
    measures its noise floor would see it. Deterministic: no random numbers.

    Inputs
    ------
    iq_in : iq
        Receiver output (echo plus noise), input-referred.
    noise_power_in : noise_power
        The receiver's noise power (optional).
    Outputs
    -------
    iq : iq
        The quantised, clipped samples, input-referred.
    noise_power : noise_power
        ``noise_power_in`` plus the quantisation noise (needs ``noise_power_in``).
    clipping : adc_clipping
        Clipped samples per gate (stored in the volume as ADC_CLIPPED; the chunk's totals in
        the attributes ``clipped_samples`` and ``clipped_gates``).
    """

    iq_in = Input(IQ, doc="receiver output, input-referred")
    noise_power_in = Input(NOISE_POWER, required=False, doc="receiver noise power")
    iq = Output(IQ, doc="quantised and clipped samples, input-referred")
    noise_power = Output(NOISE_POWER, doc="noise power plus quantisation noise")
    clipping = Output(ADC_CLIPPING, store="moments", doc="clipped samples per gate")

    bits = Param(12, type="int", min=1, max=32, doc="ADC resolution")
    full_scale_dbm = Param(
        -10.0,
        units="dBm",
        min=-200.0,
        max=60.0,
        doc="full scale at the ADC: a complex tone whose I and Q just reach the rails",
    )
    gain_db = Param(
        60.0, units="dB", min=-50.0, max=200.0, doc="receiver gain from its input to the ADC"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        if "noise_power" in connected and "noise_power_in" not in connected:
            return [
                (
                    "output 'noise_power'",
                    "needs the input 'noise_power_in' connected (the receiver's noise power)",
                )
            ]
        return []

    def rail(self) -> float:
        """The rail sqrt(P_fs) referred to the receiver input, in sqrt(W)."""
        return float(np.sqrt(10 ** ((self.p["full_scale_dbm"] - 30 - self.p["gain_db"]) / 10)))

    def step(self) -> float:
        """The quantisation step referred to the receiver input, in sqrt(W)."""
        return 2.0 * self.rail() / 2 ** int(self.p["bits"])

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        x = inputs["iq_in"]
        check_pulses(x, chunk, self.name)
        if chunk.expected and x.shape[1] > 0:
            raise ValueError(
                f"block '{self.name}' (receiver.adc): the I/Q cube has no pulses to quantise "
                "(the weather channel's 'expected' level draws none); run at 'combined' or a "
                "slower level"
            )
        step = self.step()
        bits = int(self.p["bits"])
        i, clip_i = quantise(x.real.astype(np.float64), step, bits)
        q, clip_q = quantise(x.imag.astype(np.float64), step, bits)
        out = (i + 1j * q).astype(np.complex64)
        clipped = (clip_i | clip_q).sum(axis=(2, 3)).astype(np.int32)
        ds = xr.Dataset(
            {
                "ADC_CLIPPED": (
                    ("beam", "range"),
                    clipped,
                    {"units": "count", "long_name": "samples whose I or Q hit the ADC's rails"},
                )
            },
            attrs={
                "clipped_samples": int(clipped.sum()),
                "clipped_gates": int((clipped > 0).sum()),
                "adc_step_w": float(step**2),
            },
        )
        result: dict[str, Any] = {"iq": out, "clipping": ds}
        if inputs.get("noise_power_in") is not None:
            result["noise_power"] = inputs["noise_power_in"] + step**2 / 6.0
        return result
