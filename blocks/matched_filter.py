"""Matched filtering: the range weighting a gate sees and the noise bandwidth it passes."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output

from .signals import PULSE, RANGE_RESPONSE, SPEED_OF_LIGHT


class MatchedFilter(Block):
    """Filter matched to the ideal reference waveform, applied to the radiated pulse.

    The filter is h = conj(reference reversed) / sum|reference|^2, so an undistorted pulse gives
    a peak of 1 and white noise of density N0 comes out with power N0 * B, B = fs / sum|ref|^2
    (1/tau for a rectangular pulse). A point dr beyond a gate arrives 2 dr / c late, so the gate
    sees it through the cross-correlation y of the radiated pulse with the reference at lag
    -2 dr / c; the gate's range weighting is |y|^2 (range sidelobes and amplifier distortion
    included), listed against dr in increasing order.
    """

    pulse = Input(PULSE, doc="radiated envelope")
    reference = Input(PULSE, doc="ideal waveform the filter is matched to")
    range_response = Output(RANGE_RESPONSE, doc="|y|^2 against range offset; noise bandwidth")

    @classmethod
    def warm_up(cls) -> None:
        import scipy.signal  # noqa: F401

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        import scipy.signal  # slow to import; listing and validating blocks must not pay

        tx, ref = inputs["pulse"], inputs["reference"]
        fs = float(ref.attrs["sample_rate_hz"])
        if float(tx.attrs["sample_rate_hz"]) != fs:
            raise ValueError("pulse and reference must share one sample rate")
        s = tx["envelope"].values
        r = ref["envelope"].values
        energy = float(np.sum(np.abs(r) ** 2))
        taps = np.conj(r[::-1]) / energy
        lag = np.arange(-(r.size - 1), s.size)
        y = scipy.signal.correlate(s, r, mode="full") / energy
        # Offset dr = -lag c / (2 fs); reversed so that offsets increase.
        offset_m = (-lag / fs * SPEED_OF_LIGHT / 2.0)[::-1]
        y = y[::-1]
        ds = xr.Dataset(
            {
                "power_weight": ("offset", np.abs(y) ** 2, {"units": "1"}),
                "voltage": ("offset", y, {"units": "1"}),
                "transmitted": ("sample", s.astype(np.complex128), {"units": "1"}),
                "taps": ("tap", taps.astype(np.complex128), {"units": "1"}),
            },
            coords={"offset_m": ("offset", offset_m, {"units": "m"})},
            attrs={
                "noise_bandwidth_hz": fs * float(np.sum(np.abs(taps) ** 2)),
                "sample_rate_hz": fs,
                "blind_range_m": s.size / fs * SPEED_OF_LIGHT / 2.0,
            },
        )
        return {"range_response": ds}
