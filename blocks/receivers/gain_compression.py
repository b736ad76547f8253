"""Receiver gain compression: a Rapp AM/AM on the received sum."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import IQ
from ..transmitters.amplifiers import rapp


def saturation_from_p1db(p1db_w: float, smoothness: float) -> float:
    """The Rapp saturation amplitude (sqrt(W)) whose gain is 1 dB down at input power ``p1db_w``.

    A(r) = r / (1 + (r / a_sat)^(2p))^(1/(2p)) is 1 dB below r where (r / a_sat)^(2p) =
    10^(2p / 20) - 1, so a_sat = sqrt(P1dB) / (10^(p / 10) - 1)^(1 / (2p)).
    """
    return float(np.sqrt(p1db_w) / (10 ** (smoothness / 10) - 1) ** (1 / (2 * smoothness)))


class ReceiverCompression(Block):
    """Gain compression of the receiver on the received sum (Rapp AM/AM, no AM/PM).

    Each sample (the sum of every echo at that gate and pulse, plus noise, input-referred) has
    its amplitude r mapped to r / (1 + (r / a_sat)^(2p))^(1/(2p)), phase unchanged, with a_sat
    set so the gain is 1 dB down at the input-referred 1 dB compression point ``p1db_dbm``.
    Small signals pass with unit gain, so the calibration holds below compression. Place it
    after the receiver's noise (the noise is compressed with the echo) and before the ADC.
    Deterministic: no random numbers.

    Inputs
    ------
    iq_in : iq
        Received samples, input-referred.
    Outputs
    -------
    iq : iq
        Compressed samples, input-referred.
    """

    iq_in = Input(IQ, doc="received samples")
    iq = Output(IQ, doc="compressed samples")

    p1db_dbm = Param(
        -20.0, units="dBm", min=-200.0, max=60.0, doc="input-referred 1 dB compression point"
    )
    smoothness = Param(2.0, min=0.1, max=100.0, doc="Rapp smoothness p of the knee")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        x = inputs["iq_in"]
        p = float(self.p["smoothness"])
        a_sat = saturation_from_p1db(10 ** ((self.p["p1db_dbm"] - 30) / 10), p)
        r = np.abs(x).astype(np.float64)
        gain = np.ones_like(r)
        nonzero = r > 0
        gain[nonzero] = rapp(r[nonzero] / a_sat, p) * a_sat / r[nonzero]
        return {"iq": (x * gain).astype(np.complex64)}
