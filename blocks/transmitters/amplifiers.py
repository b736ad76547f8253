"""Transmit amplifiers (HPA): how the pulse envelope is distorted before it is radiated."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import PULSE

#: The 10-90 % amplitude rise of a linear ramp is this fraction of the ramp's duration.
RAMP_10_90 = 0.8


def edge_gate(samples: int, sample_rate_hz: float, rise_s: float, fall_s: float) -> np.ndarray:
    """Amplitude gate of a pulse with linear rise and fall edges of given 10-90 % times.

    The ramps lie inside the pulse (its length is unchanged): the gate rises linearly from 0
    at the pulse start over ``rise_s / 0.8`` (so 10 % to 90 % of the amplitude takes
    ``rise_s``), is 1 in between, and falls to 0 at the pulse end over ``fall_s / 0.8``;
    sample k is taken at its centre, (k + 1/2) / fs. Zero times give a gate of ones.
    """
    width = samples / sample_rate_hz
    t = (np.arange(samples) + 0.5) / sample_rate_hz
    gate = np.ones(samples)
    if rise_s > 0:
        gate = np.minimum(gate, t / (rise_s / RAMP_10_90))
    if fall_s > 0:
        gate = np.minimum(gate, (width - t) / (fall_s / RAMP_10_90))
    return np.clip(gate, 0.0, 1.0)


class _Amplifier(Block):
    """A transmit amplifier's ports and the rise and fall times of its output (shared)."""

    pulse_in = Input(PULSE, doc="drive envelope, peak amplitude 1")
    pulse = Output(PULSE, doc="radiated envelope, 1 = rated peak power")

    rise_time_s = Param(
        0.0,
        units="s",
        min=0.0,
        max=1e-3,
        doc="10-90 % rise time of the radiated pulse (linear edge; 0: as the drive)",
    )
    fall_time_s = Param(
        0.0,
        units="s",
        min=0.0,
        max=1e-3,
        doc="90-10 % fall time of the radiated pulse (linear edge; 0: as the drive)",
    )

    def edges(self, pulse: xr.Dataset, envelope: np.ndarray) -> xr.Dataset:
        """The amplified envelope with the output's rise and fall edges, as a pulse."""
        rise, fall = self.p["rise_time_s"], self.p["fall_time_s"]
        if rise > 0 or fall > 0:
            fs = float(pulse.attrs["sample_rate_hz"])
            ramps = (rise + fall) / RAMP_10_90
            if ramps > envelope.size / fs:
                raise ValueError(
                    f"block '{self.name}': rise_time_s + fall_time_s = {rise + fall:g} s need "
                    f"linear edges of {ramps:g} s, longer than the {envelope.size / fs:g} s pulse"
                )
            envelope = envelope * edge_gate(envelope.size, fs, rise, fall)
        return pulse.copy(data={"envelope": envelope})


class IdealAmplifier(_Amplifier):
    """A linear amplifier: the pulse passes unchanged (peak power set by the radar equation),
    but for the output's rise and fall edges when they are set."""

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        ds = inputs["pulse_in"]
        if self.p["rise_time_s"] == 0 and self.p["fall_time_s"] == 0:
            return {"pulse": ds}
        return {"pulse": self.edges(ds, ds["envelope"].values)}


def saleh(
    r: np.ndarray, alpha_a: float, beta_a: float, alpha_phi: float, beta_phi: float
) -> tuple[np.ndarray, np.ndarray]:
    """Saleh AM/AM and AM/PM conversions (the paper's equations 3 and 4)."""
    r2 = r * r
    return alpha_a * r / (1.0 + beta_a * r2), alpha_phi * r2 / (1.0 + beta_phi * r2)


class SalehAmplifier(_Amplifier):
    """A solid-state HPA with Saleh AM/AM and AM/PM distortion (paper eq. 1-4).

    The drive envelope is scaled so its peak sits ``input_backoff_db`` below the input that
    saturates the amplifier (r_sat = 1/sqrt(beta_a)); the output is normalised to the saturated
    output amplitude, so peak amplitude 1 means the radar's rated peak power. The rise and
    fall edges (``rise_time_s``, ``fall_time_s``) gate the output, as the switching of the
    amplifier's supply would.
    """

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
        return {"pulse": self.edges(ds, out)}


def rapp(r: np.ndarray, smoothness: float) -> np.ndarray:
    """Rapp AM/AM conversion, input and output relative to the saturation level.

    A(r) = r / (1 + r^(2p))^(1 / (2p)): linear with unit gain for r << 1, tending to 1, and
    the sharper the knee the larger p (a hard limiter as p -> infinity).
    """
    return r / (1.0 + r ** (2.0 * smoothness)) ** (1.0 / (2.0 * smoothness))


class RappAmplifier(_Amplifier):
    """A solid-state HPA after Rapp (1991): AM/AM compression, no AM/PM.

    The drive is scaled so its peak sits ``input_backoff_db`` below the input saturation
    level (where the small-signal gain would reach the saturated output; negative values
    overdrive), and the output is normalised to the saturated output, so amplitude 1 is the
    radar's rated peak power (the weather channel's ``peak_power_w``). At 0 dB the peak comes
    out at 2^(-1/(2p)) in amplitude, 3.01 / p dB below the rated power. The phase passes
    unchanged: the Rapp model has no AM/PM. Rise and fall edges as ``amplifier.saleh``.
    """

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
        return {"pulse": self.edges(ds, out)}
