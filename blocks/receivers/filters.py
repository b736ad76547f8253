"""Receive filters: the range response a gate sees and the noise bandwidth it passes.

A filter is its impulse response h at the waveform's sample rate. A point dr beyond a gate
arrives 2 dr / c late, so the gate sees it through y = s * h (the radiated pulse s convolved
with h) at the lag -2 dr / c from the filter's alignment; the range weighting is |y|^2 (range
sidelobes and amplifier distortion included), listed against dr in increasing order. Every
filter is scaled so that the undistorted reference gives y = 1 at zero offset; white noise of
density N0 then comes out with power N0 B, B = fs sum|h|^2. The SNR loss is that of peak SNR
against the filter matched to the radiated pulse (compression.snr_loss_db).

Three filters: ``filter.matched`` with ``reference`` from the waveform is matched to the ideal
pulse (what a real receiver holds); fed the amplifier's output as ``reference`` it is matched
to the radiated (distorted) pulse; ``filter.mismatched`` weights the matched filter by a window
in time or in frequency (lower sidelobes at an SNR loss).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import PULSE, RANGE_RESPONSE, SPEED_OF_LIGHT
from ..waveforms.pulse_compression import convolve_full, snr_loss_db


def range_response(
    pulse: np.ndarray, taps: np.ndarray, sample_rate_hz: float, zero_index: int
) -> xr.Dataset:
    """The range_response Dataset of filter ``taps`` for the radiated ``pulse``.

    ``zero_index`` is the output sample (of the full convolution) at which a scatterer at the
    gate itself appears: where the reference's mainlobe peaks.
    """
    fs = float(sample_rate_hz)
    y = convolve_full(pulse, taps)
    lag = np.arange(y.size) - zero_index
    # Offset dr = -lag c / (2 fs); reversed so that offsets increase.
    offset_m = (-lag / fs * SPEED_OF_LIGHT / 2.0)[::-1]
    y = y[::-1]
    return xr.Dataset(
        {
            "power_weight": ("offset", np.abs(y) ** 2, {"units": "1"}),
            "voltage": ("offset", y.astype(np.complex128), {"units": "1"}),
            "transmitted": ("sample", pulse.astype(np.complex128), {"units": "1"}),
            "taps": ("tap", taps.astype(np.complex128), {"units": "1"}),
        },
        coords={"offset_m": ("offset", offset_m, {"units": "m"})},
        attrs={
            "noise_bandwidth_hz": fs * float(np.sum(np.abs(taps) ** 2)),
            "sample_rate_hz": fs,
            "blind_range_m": pulse.size / fs * SPEED_OF_LIGHT / 2.0,
            "snr_loss_db": snr_loss_db(pulse, taps),
        },
    )


#: Attributes of the radiated pulse handed on to the range response: a power divider's split
#: (``transmitter.power_divider``), which the weather channel's calibration reports.
DIVIDER_ATTRS = ("power_divider_ports", "power_divider_loss_db")


def with_transmit_attrs(response: xr.Dataset, pulse: xr.Dataset) -> xr.Dataset:
    """``response`` with the radiated pulse's power-divider attributes, when it has them."""
    response.attrs.update({k: pulse.attrs[k] for k in DIVIDER_ATTRS if k in pulse.attrs})
    return response


def _pulse_and_reference(inputs: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, float]:
    tx, ref = inputs["pulse"], inputs["reference"]
    fs = float(ref.attrs["sample_rate_hz"])
    if float(tx.attrs["sample_rate_hz"]) != fs:
        raise ValueError(
            f"pulse and reference must share one sample rate (pulse "
            f"{float(tx.attrs['sample_rate_hz']):g} Hz, reference {fs:g} Hz)"
        )
    return tx["envelope"].values, ref["envelope"].values, fs


class MatchedFilter(Block):
    """Filter matched to the reference waveform, applied to the radiated pulse.

    h = conj(reference reversed) / sum|reference|^2, so an undistorted pulse gives a peak of 1
    and the noise bandwidth is fs / sum|reference|^2 (1/tau for a rectangular pulse). Feed it
    the waveform as ``reference`` for the filter a receiver holds (matched to the ideal
    pulse), or the amplifier's output for the filter matched to the radiated pulse (SNR loss
    0).
    """

    pulse = Input(PULSE, doc="radiated envelope")
    reference = Input(PULSE, doc="waveform the filter is matched to")
    range_response = Output(RANGE_RESPONSE, doc="|y|^2 against range offset; noise bandwidth")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        s, r, fs = _pulse_and_reference(inputs)
        taps = np.conj(r[::-1]) / float(np.sum(np.abs(r) ** 2))
        response = range_response(s, taps, fs, r.size - 1)
        return {"range_response": with_transmit_attrs(response, inputs["pulse"])}


def window_samples(name: str, n: int, params: dict[str, Any]) -> np.ndarray:
    """``n`` samples of the named window (scipy.signal.windows), peak 1."""
    import scipy.signal.windows as windows

    if name == "taylor":
        w = windows.taylor(n, nbar=params["taylor_nbar"], sll=-params["taylor_sidelobe_db"])
    elif name == "kaiser":
        w = windows.kaiser(n, params["kaiser_beta"])
    else:
        raise ValueError(f"unknown window {name!r}")
    return w / np.max(w)


class MismatchedFilter(Block):
    """The matched filter weighted by a window: lower range sidelobes, a small SNR loss.

    ``domain = time``: h = conj(reference reversed) x w over the pulse (for an LFM the same as
    weighting its spectrum, by stationary phase). ``domain = frequency``: H(f) = conj(R(f))
    W(f / B), the window spread over the band B (``band_hz``, or the reference's bandwidth)
    and zero outside, on an FFT of twice the pulse length; the filter is that long, centred.
    The loss of peak SNR against the matched filter is in the output's ``snr_loss_db``:
    for a constant-envelope pulse weighted in time it is the window's processing loss,
    -10 log10((sum w)^2 / (N sum w^2)).
    """

    pulse = Input(PULSE, doc="radiated envelope")
    reference = Input(PULSE, doc="waveform the filter is matched to before weighting")
    range_response = Output(RANGE_RESPONSE, doc="|y|^2 against range offset; noise bandwidth")

    window = Param("taylor", type="str", choices=("taylor", "kaiser"), doc="weighting window")
    domain = Param(
        "time", type="str", choices=("time", "frequency"), doc="weight in time or in frequency"
    )
    taylor_sidelobe_db = Param(
        -40.0, units="dB", min=-150.0, max=-13.0, doc="Taylor window sidelobe level"
    )
    taylor_nbar = Param(
        5, type="int", min=1, max=100, doc="Taylor window: number of near sidelobes held level"
    )
    kaiser_beta = Param(6.0, min=0.0, max=50.0, doc="Kaiser window shape parameter beta")
    band_hz = Param(
        None,
        units="Hz",
        min=1e3,
        max=1e11,
        optional=True,
        doc="frequency weighting: band the window spans (default: the reference's bandwidth)",
    )

    @classmethod
    def warm_up(cls) -> None:
        import scipy.signal  # noqa: F401

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        import scipy.fft
        import scipy.signal

        s, r, fs = _pulse_and_reference(inputs)
        if self.p["domain"] == "time":
            taps = np.conj(r[::-1]) * window_samples(self.p["window"], r.size, self.p)[::-1]
            zero = r.size - 1
        else:
            band = self.p["band_hz"]
            if band is None:
                band = inputs["reference"].attrs.get("bandwidth_hz")
            if band is None:
                raise ValueError(
                    "frequency weighting needs the band: set band_hz (the reference carries "
                    "no bandwidth_hz)"
                )
            n_fft = scipy.fft.next_fast_len(2 * r.size)
            f = scipy.fft.fftfreq(n_fft, 1.0 / fs)
            inside = np.abs(f) <= band / 2
            weight = np.zeros(n_fft)
            order = np.argsort(f[inside])
            w = window_samples(self.p["window"], int(inside.sum()), self.p)
            weight[np.flatnonzero(inside)[order]] = w
            h = scipy.fft.ifft(np.conj(scipy.fft.fft(r, n_fft)) * weight)
            # conj(R) alone is the reversed reference wrapped to start at 1 - size; centre it.
            shift = r.size - 1 + (n_fft - r.size) // 2
            taps = np.roll(h, shift)
            zero = shift
        y_ref = scipy.signal.convolve(r, taps, mode="full")
        taps = taps / y_ref[zero]
        response = range_response(s, taps, fs, zero)
        return {"range_response": with_transmit_attrs(response, inputs["pulse"])}
