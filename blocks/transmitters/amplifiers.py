"""Transmit amplifiers (HPA): how the pulse envelope is distorted before it is radiated."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import PULSE


class IdealAmplifier(Block):
    """A linear amplifier: the pulse passes unchanged (peak power set by the radar equation)."""

    pulse_in = Input(PULSE, doc="drive envelope")
    pulse = Output(PULSE, doc="radiated envelope, peak amplitude 1 at peak power")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        return {"pulse": inputs["pulse_in"]}


def saleh(
    r: np.ndarray, alpha_a: float, beta_a: float, alpha_phi: float, beta_phi: float
) -> tuple[np.ndarray, np.ndarray]:
    """Saleh AM/AM and AM/PM conversions (the paper's equations 3 and 4)."""
    r2 = r * r
    return alpha_a * r / (1.0 + beta_a * r2), alpha_phi * r2 / (1.0 + beta_phi * r2)


class SalehAmplifier(Block):
    """A solid-state HPA with Saleh AM/AM and AM/PM distortion (paper eq. 1-4).

    The drive envelope is scaled so its peak sits ``input_backoff_db`` below the input that
    saturates the amplifier (r_sat = 1/sqrt(beta_a)); the output is normalised to the saturated
    output amplitude, so peak amplitude 1 means the radar's rated peak power.
    """

    pulse_in = Input(PULSE, doc="drive envelope, peak amplitude 1")
    pulse = Output(PULSE, doc="distorted envelope, 1 = saturated output")

    alpha_a = Param(2.1587, min=0.0, doc="AM/AM gain coefficient")
    beta_a = Param(1.1517, min=1e-9, doc="AM/AM compression coefficient")
    alpha_phi = Param(4.0033, units="rad", doc="AM/PM coefficient")
    beta_phi = Param(9.1040, min=0.0, doc="AM/PM saturation coefficient")
    input_backoff_db = Param(
        0.0, units="dB", min=0.0, max=60.0, doc="drive peak below the saturating input"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        ds = inputs["pulse_in"]
        env = ds["envelope"].values
        r_sat = 1.0 / np.sqrt(self.p["beta_a"])
        drive = env * r_sat * 10 ** (-self.p["input_backoff_db"] / 20)
        amp, phase = saleh(
            np.abs(drive),
            self.p["alpha_a"],
            self.p["beta_a"],
            self.p["alpha_phi"],
            self.p["beta_phi"],
        )
        a_max = self.p["alpha_a"] * r_sat / 2.0  # A(r_sat)
        out = amp / a_max * np.exp(1j * (np.angle(drive) + phase))
        return {"pulse": ds.copy(data={"envelope": out})}


def rapp(r: np.ndarray, smoothness: float) -> np.ndarray:
    """Rapp AM/AM conversion, input and output relative to the saturation level.

    A(r) = r / (1 + r^(2p))^(1 / (2p)): linear with unit gain for r << 1, tending to 1, and
    the sharper the knee the larger p (a hard limiter as p -> infinity).
    """
    return r / (1.0 + r ** (2.0 * smoothness)) ** (1.0 / (2.0 * smoothness))


class RappAmplifier(Block):
    """A solid-state HPA after Rapp (1991): AM/AM compression, no AM/PM.

    The drive is scaled so its peak sits ``input_backoff_db`` below the input saturation
    level (where the small-signal gain would reach the saturated output; negative values
    overdrive), and the output is normalised to the saturated output, so amplitude 1 is the
    radar's rated peak power (the weather channel's ``peak_power_w``). At 0 dB the peak comes
    out at 2^(-1/(2p)) in amplitude, 3.01 / p dB below the rated power. The phase passes
    unchanged: the Rapp model has no AM/PM.
    """

    pulse_in = Input(PULSE, doc="drive envelope, peak amplitude 1")
    pulse = Output(PULSE, doc="compressed envelope, 1 = saturated output")

    smoothness = Param(
        2.0, min=0.1, max=100.0, doc="Rapp smoothness p of the knee (large: hard limiter)"
    )
    input_backoff_db = Param(
        0.0,
        units="dB",
        min=-20.0,
        max=60.0,
        doc="drive peak below the input saturation level (negative: overdrive)",
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        ds = inputs["pulse_in"]
        drive = ds["envelope"].values * 10 ** (-self.p["input_backoff_db"] / 20)
        out = rapp(np.abs(drive), self.p["smoothness"]) * np.exp(1j * np.angle(drive))
        return {"pulse": ds.copy(data={"envelope": out})}
