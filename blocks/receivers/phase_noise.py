"""Local-oscillator phase noise, applied coherently on transmit and receive with the range delay.

One oscillator (the synthesiser or DDS that both up- and down-converts) has a random phase
phi(t). A pulse leaves at t_m = m T carrying phi(t_m); its echo from range r returns at
t_m + tau, tau = 2 r / c, and is mixed down with phi(t_m + tau). The sample of gate r on
pulse m is therefore multiplied by exp(j (phi(t_m) - phi(t_m + tau))): the echo sees the
phase difference across its own round trip. For tau short against the noise's correlation
time the two phases cancel (near clutter stays coherent); for tau long they are independent
and the echo's phase wanders with twice the oscillator's phase variance. The difference
D(t) = phi(t) - phi(t + tau) has the one-sided spectrum 4 S_phi(f) sin^2(pi f tau).

The oscillator is given as a datasheet gives it: single-sideband phase noise L(f) in dBc/Hz
at offsets f (``profile_dbc_hz``, "offset_hz:dBc, ..."), interpolated linearly in dB against
log offset, held at its first value below the first offset, and zero beyond the last offset
and, when the receive filter is connected, beyond half its noise bandwidth (phase noise
outside the receiver's band is filtered off with the echo energy it spreads there, which this
block does not account as a loss). The phase's one-sided spectrum is S_phi = 2 x 10^(L / 10)
rad^2 / Hz (small angles), so its variance is 2 x the integral of L.

Synthesis: per beam, a real Gaussian process on a uniform grid of ``OVERSAMPLE`` x 2 x the
highest offset, spanning the dwell (pulse times and every gate's return), by shaping white
noise in the frequency domain (FFT), then read at the pulse and return times by linear
interpolation (the interpolation lowers the power near the top offset by at most
sinc^4(1 / (2 OVERSAMPLE)), 0.45 dB at the very top). The white noise comes from the beam's own
random stream, so a beam gets the same phases whatever the chunking. H and V share the one
oscillator (the same phase on both channels). Placed between the receiver and the processor,
the factor also multiplies the thermal noise, which stays circular white Gaussian: the same in
distribution as noise added after the mixer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import CALIBRATION, IQ, RANGE_RESPONSE, SPEED_OF_LIGHT, check_pulses

#: Grid rate over the Nyquist rate of the highest offset.
OVERSAMPLE = 4
#: At most this many grid points per beam (2^24: 128 MB of float64 per beam, transient).
MAX_GRID = 1 << 24


def parse_profile(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (Hz, ascending) and levels (dBc/Hz) of "offset_hz:dBc, offset_hz:dBc, ..."."""
    points = []
    for item in str(text).replace(";", ",").split(","):
        if not item.strip():
            continue
        try:
            f, level = (float(v) for v in item.split(":"))
        except ValueError:
            raise ValueError(
                f"profile point {item.strip()!r}: expected OFFSET_HZ:DBC_PER_HZ, e.g. 1e4:-100"
            ) from None
        if not (np.isfinite(f) and f > 0 and np.isfinite(level)):
            raise ValueError(f"profile point {item.strip()!r}: offset must be > 0, both finite")
        if level > 0:
            raise ValueError(f"profile point {item.strip()!r}: a level above 0 dBc/Hz")
        points.append((f, level))
    if not points:
        raise ValueError("the profile has no points")
    f, level = np.array(points).T
    if np.any(np.diff(f) <= 0):
        raise ValueError("profile offsets must increase strictly")
    return f, level


def phase_psd(freq_hz: np.ndarray, offsets: np.ndarray, levels_dbc: np.ndarray) -> np.ndarray:
    """One-sided PSD of the phase, S_phi(f) = 2 x 10^(L(f) / 10) rad^2/Hz (0 beyond the
    profile's last offset; held below its first)."""
    f = np.asarray(freq_hz, dtype=float)
    logf = np.log10(np.clip(f, offsets[0], offsets[-1]))
    level = np.interp(logf, np.log10(offsets), levels_dbc)
    return np.where(f <= offsets[-1], 2 * 10 ** (level / 10), 0.0)


def synthesise(
    gen: np.random.Generator, n: int, rate_hz: float, offsets: np.ndarray, levels: np.ndarray
) -> np.ndarray:
    """n samples at ``rate_hz`` of a stationary Gaussian phase with the profile's spectrum."""
    spec = np.fft.rfft(gen.standard_normal(n))
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    gain = np.sqrt(phase_psd(f, offsets, levels) * rate_hz / 2)
    gain[0] = 0.0  # no mean phase
    return np.fft.irfft(spec * gain, n)


class PhaseNoise(Block):
    """Oscillator phase noise on every echo, coherent on transmit and receive (see module).

    Inputs
    ------
    iq_in : iq
        Received samples (echo and noise).
    calibration : calibration
        Gate ranges and the PRT.
    range_response : range_response, optional
        The receive filter: the profile is cut at half its noise bandwidth.
    Outputs
    -------
    iq : iq
        Samples with each gate's round-trip phase difference.
    """

    iq_in = Input(IQ, doc="received samples")
    calibration = Input(CALIBRATION, doc="gate ranges and PRT")
    range_response = Input(
        RANGE_RESPONSE, required=False, doc="receive filter: cut the profile at half its band"
    )
    iq = Output(IQ, doc="samples with the oscillator's round-trip phase noise")

    profile_dbc_hz = Param(
        "1e3:-100, 1e7:-100",
        type="str",
        doc="SSB phase noise, 'offset_hz:dBc/Hz, ...' (log-linear between points)",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        try:
            parse_profile(params.get("profile_dbc_hz", cls.params["profile_dbc_hz"].default))
        except ValueError as exc:
            return [("parameter 'profile_dbc_hz'", str(exc))]
        return []

    def grid(self, pulses: int, prt_s: float, delays: np.ndarray, top_hz: float) -> tuple:
        """The synthesis grid: (number of points, rate)."""
        rate = 2 * OVERSAMPLE * top_hz
        span = (pulses - 1) * prt_s + float(delays.max(initial=0.0))
        n = 1 << int(np.ceil(np.log2(max(16, span * rate + 2))))
        if n > MAX_GRID:
            raise ValueError(
                f"block '{self.name}': the phase-noise grid needs {n} points per beam "
                f"({span:g} s at {rate:g} Hz); lower the profile's last offset or connect "
                "'range_response' to cut it at the receiver's band"
            )
        return n, rate

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        iq = inputs["iq_in"]
        check_pulses(iq, chunk, self.name)
        pulses = iq.shape[2]
        if chunk.expected and iq.shape[1] == 0:
            return {"iq": iq}
        if chunk.expected:
            raise ValueError(
                f"block '{self.name}': the I/Q cube has no pulses (weather method 'expected'); "
                "phase noise needs drawn pulses (method 'combined' or slower)"
            )
        offsets, levels = parse_profile(self.p["profile_dbc_hz"])
        rr = inputs.get("range_response")
        if rr is not None:
            cut = float(rr.attrs["noise_bandwidth_hz"]) / 2
            if cut <= offsets[0]:
                offsets, levels = np.array([cut]), levels[:1]
            elif cut < offsets[-1]:
                level_cut = np.interp(np.log10(cut), np.log10(offsets), levels)
                keep = offsets < cut
                offsets = np.append(offsets[keep], cut)
                levels = np.append(levels[keep], level_cut)
        cal = inputs["calibration"]
        prt = float(cal.attrs["prt_s"])
        delays = 2 * np.asarray(cal["range"].values, dtype=float) / SPEED_OF_LIGHT
        n, rate = self.grid(pulses, prt, delays, float(offsets[-1]))
        grid_t = np.arange(n) / rate
        t_tx = np.arange(pulses) * prt
        t_rx = t_tx[None, :] + delays[:, None]  # (range, pulse)
        out = np.empty_like(iq)
        for i, beam in enumerate(chunk.beams):
            phi = synthesise(chunk.rng(int(beam)), n, rate, offsets, levels)
            diff = np.interp(t_tx, grid_t, phi)[None, :] - np.interp(t_rx, grid_t, phi)
            out[i] = iq[i] * np.exp(1j * diff).astype(np.complex64)[..., None]
        return {"iq": out}
