"""Pulse-compression test signals for the weather channel's fast-time tests.

The waveform blocks live elsewhere; these tests build what they need on the range-response
contract (``blocks/signals.py``: ``transmitted``, ``taps``, ``voltage``, ``power_weight``,
``offset_m``, ``sample_rate_hz``, ``noise_bandwidth_hz``, ``blind_range_m``) by passing an
envelope through the library's matched filter.
"""

from __future__ import annotations

import numpy as np
import scipy.signal
from pasim_blocks.receivers.filters import MatchedFilter
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.waveforms.pulses import RectangularPulse, pulse_dataset

from pasim_graph import Chunk

NO_BEAMS = np.arange(0)
LAMBDA = SPEED_OF_LIGHT / 2.8e9


def lfm(bandwidth_hz, width_s, sample_rate_hz, taylor_sll_db=None):
    """Linear FM envelope centred on zero frequency, optionally Taylor-windowed in amplitude."""
    n = round(width_s * sample_rate_hz)
    t = (np.arange(n) - (n - 1) / 2) / sample_rate_hz
    env = np.exp(1j * np.pi * bandwidth_hz / width_s * t**2)
    if taylor_sll_db is not None:
        env = env * scipy.signal.windows.taylor(n, nbar=5, sll=taylor_sll_db, norm=True)
    return env


def matched(envelope, sample_rate_hz):
    """The range response of ``envelope`` radiated as is and matched-filtered."""
    pulse = pulse_dataset(envelope, sample_rate_hz)
    return MatchedFilter(name="mf").process(
        {"pulse": pulse, "reference": pulse}, Chunk(beams=NO_BEAMS)
    )["range_response"]


def rectangular(width_s=1.6e-6, sample_rate_hz=20e6):
    pulse = RectangularPulse(name="tx", width_s=width_s, sample_rate_hz=sample_rate_hz)
    return matched(
        pulse.process({}, Chunk(beams=NO_BEAMS))["pulse"]["envelope"].values, sample_rate_hz
    )
