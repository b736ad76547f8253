"""I/Q gain and phase imbalance of a quadrature demodulator."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import IQ


def image_rejection_db(gain_db: float, phase_deg: float) -> float:
    """Image rejection ratio (1 + 2 g cos phi + g^2) / (1 - 2 g cos phi + g^2), in dB."""
    g = 10 ** (gain_db / 20)
    c = 2 * g * np.cos(np.deg2rad(phase_deg))
    return float(10 * np.log10((1 + c + g * g) / (1 - c + g * g)))


class IQImbalance(Block):
    """Gain and phase imbalance between the I and Q rails (the image it makes).

    I is the reference; Q comes out with amplitude ratio g = 10^(gain_db / 20) and a phase
    error phi: I' = I, Q' = g (Q cos phi + I sin phi). A tone exp(j w t) then becomes
    mu exp(j w t) + nu exp(-j w t), mu = (1 + g e^{j phi}) / 2, nu = (1 - g e^{-j phi}) / 2:
    an image at the mirrored Doppler frequency, |mu|^2 / |nu|^2 = (1 + 2 g cos phi + g^2) /
    (1 - 2 g cos phi + g^2) below the tone (the image rejection ratio). H and V receivers get
    the same imbalance. Deterministic: no random numbers.

    Inputs
    ------
    iq_in : iq
        Received samples.
    Outputs
    -------
    iq : iq
        Samples with the image.
    """

    iq_in = Input(IQ, doc="received samples")
    iq = Output(IQ, doc="samples with the I/Q image")

    gain_imbalance_db = Param(0.0, units="dB", min=-10.0, max=10.0, doc="Q rail gain over I")
    phase_imbalance_deg = Param(
        0.0, units="deg", min=-45.0, max=45.0, doc="Q rail phase error from quadrature"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        x = inputs["iq_in"]
        g = 10 ** (self.p["gain_imbalance_db"] / 20)
        phi = np.deg2rad(self.p["phase_imbalance_deg"])
        i = x.real
        q = np.float32(g * np.cos(phi)) * x.imag + np.float32(g * np.sin(phi)) * i
        return {"iq": (i + 1j * q).astype(np.complex64)}
