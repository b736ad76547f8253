"""Pulse-to-pulse amplitude and phase jitter of the transmitters (thermal HPA instability).

The paper's section 2.2.2 names the HPAs' complex gain drifting from pulse to pulse with
temperature as a major instability that lowers the system's coherency. This block sits on the
I/Q port between the weather channel and the receiver and multiplies every echo of a pulse by
that pulse's transmit gain (echoes are linear in the transmitted field; the receive path has
no jitter here).

Model: ``transmitters`` independent amplifiers (the array's T/R modules, or one HPA) each have,
on every pulse and port, a gain 10^(a/20) exp(j phi) with a ~ N(0, ``amplitude_jitter_db``^2)
and phi ~ N(0, ``phase_jitter_deg``^2), independent from pulse to pulse; the H and V amplifiers
of one module have deviates correlated by ``hv_correlation`` (1: one amplifier feeds both
ports). The beam's transmit gain on a pulse is the mean of the N gains (their coherent sum on
the beam axis, for equal drive): the jitter averages down as 1/N in variance, while its mean
loss stays. The pulse-to-pulse fluctuation of the sidelobes is not modelled.

Transmission modes (the weather channel's, read from its calibration output): in SHV both
transmitters fire every pulse and the H port's echo takes the H transmitter's gain, the V
port's the V one's (exact without cross-polar coupling; with it, the part of a port's echo
that the other port's transmission leaked into is off by the ratio of the two gains, a
product of two small quantities). In AHV a pulse has one transmitter (H on even pulses, V on
odd ones), whose gain multiplies the echo at both ports: exact.

At the weather channel's ``expected`` level (``chunk.expected``: no pulses) the expected
correlations are scaled by the exact moments of that gain instead: lag 0 by E|G|^2, lags
between different pulses by |E G|^2 (independent pulses), and the lag-0 H-V
cross-correlation by E[G_H* G_V].
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import CALIBRATION, CORRELATION_PRODUCTS, ECHO_CORRELATIONS, IQ, check_pulses

# Deviates drawn per block of this many (transmitter x pulse) pairs, to bound memory.
_BLOCK = 1 << 20


def jitter_moments(
    amplitude_db: float, phase_deg: float, transmitters: int, hv_correlation: float
) -> dict[str, complex]:
    """Exact moments of the mean gain G of N jittering transmitters (see the module).

    Returns ``mean`` (E G), ``power`` (E|G|^2) and ``cross`` (E[G_H* G_V]).
    """
    s = np.log(10) / 20 * amplitude_db  # the gain's log-amplitude deviation, nepers
    phi = np.deg2rad(phase_deg)
    c = hv_correlation
    mean = np.exp(s**2 / 2 - phi**2 / 2)
    single_power = np.exp(2 * s**2)
    single_cross = np.exp(s**2 * (1 + c) - phi**2 * (1 - c))
    n = transmitters
    return {
        "mean": complex(mean),
        "power": complex(single_power / n + (1 - 1 / n) * mean**2),
        "cross": complex(single_cross / n + (1 - 1 / n) * mean**2),
    }


class TransmitterJitter(Block):
    """Pulse-to-pulse transmitter gain jitter on every echo (see the module docstring)."""

    iq_in = Input(IQ, doc="echo voltages from the weather channel")
    echo_correlations_in = Input(ECHO_CORRELATIONS, doc="expected echo correlations")
    calibration = Input(CALIBRATION, doc="the weather channel's transmission mode (SHV or AHV)")
    iq = Output(IQ, doc="echo voltages with each pulse's transmit gain")
    echo_correlations = Output(ECHO_CORRELATIONS, doc="expected correlations with the jitter")

    amplitude_jitter_db = Param(
        0.1, units="dB", min=0.0, max=10.0, doc="pulse-to-pulse amplitude jitter per amplifier, rms"
    )
    phase_jitter_deg = Param(
        1.0, units="deg", min=0.0, max=180.0, doc="pulse-to-pulse phase jitter per amplifier, rms"
    )
    transmitters = Param(
        1, type="int", min=1, max=100_000, doc="independent amplifiers whose gains add in the beam"
    )
    hv_correlation = Param(
        0.0,
        min=0.0,
        max=1.0,
        doc="correlation of the H and V amplifiers' jitter (1: one amplifier)",
    )

    def gains(self, gen: np.random.Generator, pulses: int) -> np.ndarray:
        """Mean transmit gain of the N amplifiers, per pulse and port: (pulse, 2)."""
        n = self.p["transmitters"]
        s = np.log(10) / 20 * self.p["amplitude_jitter_db"]
        phi = np.deg2rad(self.p["phase_jitter_deg"])
        c = self.p["hv_correlation"]
        out = np.zeros((pulses, 2), complex)
        step = max(1, _BLOCK // n)
        for a in range(0, pulses, step):
            b = min(pulses, a + step)
            # amplitude and phase deviates of H, and the independent parts of V's
            z = gen.standard_normal((4, b - a, n))
            amp = np.stack([z[0], c * z[0] + np.sqrt(1 - c**2) * z[2]])
            ph = np.stack([z[1], c * z[1] + np.sqrt(1 - c**2) * z[3]])
            out[a:b] = np.mean(np.exp(s * amp + 1j * phi * ph), axis=-1).T
        return out

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        iq = inputs["iq_in"]
        corr = np.array(inputs["echo_correlations_in"], dtype=np.complex128, copy=True)
        m = jitter_moments(
            self.p["amplitude_jitter_db"],
            self.p["phase_jitter_deg"],
            self.p["transmitters"],
            self.p["hv_correlation"],
        )
        for i, name in enumerate(CORRELATION_PRODUCTS):
            corr[..., i] *= correlation_scale(name, m)
        check_pulses(iq, chunk, self.name)
        if chunk.expected:
            return {"iq": iq, "echo_correlations": corr}
        pulses = iq.shape[2]
        alternate = inputs["calibration"].attrs.get("transmission", "shv") == "ahv"
        out = np.empty_like(iq)
        for i, beam in enumerate(chunk.beams):
            g = self.gains(chunk.rng(int(beam)), pulses).astype(np.complex64)
            if alternate:
                # Pulse m is transmitted by port m % 2 alone; both ports receive its echo.
                g = np.repeat(g[np.arange(pulses), np.arange(pulses) % 2][:, None], 2, axis=1)
            out[i] = iq[i] * g[None, :, :]
        return {"iq": out, "echo_correlations": corr}


def correlation_scale(name: str, moments: dict[str, complex]) -> complex:
    """What the jitter does to an expected correlation product (``CORRELATION_PRODUCTS``).

    Lag 0 of one port: E|G|^2; products of two different pulses: |E G|^2 (independent gains,
    whichever transmitters); the lag-0 H-V product: E[G_H* G_V].
    """
    if name in ("R0_H", "R0_V"):
        return moments["power"]
    if name == "R0_HV":
        return moments["cross"]
    return complex(abs(moments["mean"]) ** 2)
