"""Multiple-trip echoes: the echoes of earlier pulses from beyond the unambiguous range.

At pulse m the receiver samples, at the delay of apparent range r, the echo of pulse m from
r (trip 1) and the echoes of pulses m - k from r + c (t_m - t_(m-k)) / 2 (trip k + 1), t the
transmit times (m T for a uniform PRT, alternating T1, T2 steps when staggered). The weather
channel draws every truth gate's series as if it were first-trip (each with its own
radar-equation power, 1 / R^2 of its true range), and :func:`fold_trips` sums them onto the
apparent gates: a storm at 200 km seen with a 1 ms PRT (r_a = 150 km) appears at 50 km with
its power at 200 km, i.e. 20 log10(200 / 50) = 12 dB below its reflectivity once calibrated
for 50 km. Each echo carries the transmit phase of the pulse that made it (phase-coded
scans), with that pulse's phase error and amplitude when the transmitter is not ideal.
Gates at or beyond the unambiguous range c T1 / 2 hold no sample.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import xarray as xr

from ..signals import SPEED_OF_LIGHT
from ..timing import code_errors, prt_ratio, transmit_phase


def transmit_times(indices: np.ndarray, prt_s: float, ratio: Fraction | None) -> np.ndarray:
    """Transmit times (s) of pulses ``indices`` (negative: before the dwell), pulse 0 at 0."""
    j = np.asarray(indices, np.int64)
    if ratio is None:
        return j * prt_s
    t2 = prt_s / float(ratio)
    # Pairs (T1 + T2) plus a T1 for an odd index: pulse 2q is q (T1 + T2) after pulse 0.
    q, odd = np.divmod(j, 2)
    return q * (prt_s + t2) + odd * prt_s


def trip_offsets(
    pulses: int, prt_s: float, ratio: Fraction | None, gate_m: float, trips: int
) -> np.ndarray:
    """Gate offset of trip k + 1 at each pulse (trips x pulses), to the nearest gate."""
    m = np.arange(pulses)
    t = transmit_times(m, prt_s, ratio)
    return np.stack(
        [
            np.rint(SPEED_OF_LIGHT * (t - transmit_times(m - k, prt_s, ratio)) / 2 / gate_m)
            for k in range(trips)
        ]
    ).astype(np.int64)


def trip_count(rng_m: np.ndarray, prt_s: float) -> int:
    """Trips a truth reaching ``rng_m[-1]`` holds at unambiguous range c T / 2 (1: none)."""
    r_a = SPEED_OF_LIGHT * prt_s / 2
    return int(np.floor(max(rng_m[-1] - rng_m[0], 0.0) / r_a)) + 1 if r_a <= rng_m[-1] else 1


def fold_trips(
    iq: np.ndarray,
    offsets: np.ndarray,
    visible: np.ndarray,
    phase: np.ndarray | None,
    amplitude: np.ndarray | None = None,
) -> np.ndarray:
    """Sum the trips of ``iq`` (beam x pol x gate x pulse, every truth gate as first-trip)
    onto the apparent gates ``visible`` (bool per gate); ``phase`` (beam x pulse, rad) is the
    transmit phase of each pulse of the dwell, taken as periodic (None: no code), and
    ``amplitude`` (beam x pulse) its voltage amplitude over the nominal (None: 1)."""
    n_g, pulses = iq.shape[2:]
    out = np.zeros_like(iq)
    gates = np.flatnonzero(visible)
    for k, off in enumerate(offsets):
        src = gates[:, None] + off[None, :]  # gate x pulse
        ok = src < n_g
        if not ok.any():
            continue
        cols = np.broadcast_to(np.arange(pulses), src.shape)
        part = np.where(ok, iq[:, :, np.minimum(src, n_g - 1), cols], 0)
        if phase is not None:
            # Trip k + 1 at pulse m was sent by pulse m - k.
            part = part * np.exp(1j * np.roll(phase, k, axis=-1))[:, None, None, :].astype(iq.dtype)
        if amplitude is not None:
            part = part * np.roll(amplitude, k, axis=-1)[:, None, None, :].astype(part.real.dtype)
        out[:, :, gates] += part
    return out


def overlaid_power(power: np.ndarray, offsets: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """Expected power of the other trips on each apparent gate (beam x gate), from the
    first-trip power of every truth gate (beam x gate), with pulse 0's offsets."""
    n_g = power.shape[-1]
    out = np.zeros_like(power)
    gates = np.flatnonzero(visible)
    for off in offsets[1:, -1]:
        src = gates + off
        ok = src < n_g
        out[:, gates[ok]] += power[:, src[ok]]
    return out


def fold_echo(
    iq: np.ndarray,
    corr: np.ndarray,
    beams: xr.Dataset,
    rng_m: np.ndarray,
    gate_m: float,
    method: str,
    range_folding: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The trips folded onto the apparent gates (:mod:`pasim_blocks.weather.trips`):
    the I/Q, the correlations (the gate's own trip; nothing beyond the unambiguous
    range) and the other trips' power over the gate's own (dB). None when nothing folds
    and no phase code is transmitted."""
    prt = float(beams["prt"].values[0])
    pulses = int(beams["pulses"].values)
    ratio = prt_ratio(beams)
    phase = transmit_phase(beams, pulses)
    trips = trip_count(rng_m, prt) if range_folding else 1
    if trips == 1 and phase is None:
        return None
    if method == "expected" and phase is not None:
        raise ValueError(
            "a phase code (scan.ppi's phase_code) needs time series: the weather "
            "channel's method 'expected' has none (use combined, covariance or "
            "monte_carlo, or phase_code none)"
        )
    if method == "expected":
        raise ValueError(
            "range folding and phase codes need time series: the weather channel's "
            "method 'expected' has none (use combined, covariance or monte_carlo, or set "
            "range_folding false)"
        )
    r_a = SPEED_OF_LIGHT * prt / 2
    visible = rng_m < r_a if trips > 1 else np.ones(rng_m.size, bool)
    offsets = trip_offsets(pulses, prt, ratio, gate_m, trips)
    errors = code_errors(beams, pulses) if phase is not None else None
    if errors is None:
        folded = fold_trips(iq, offsets, visible, phase)
    else:  # the echoes carry what was transmitted: the code with its errors
        folded = fold_trips(iq, offsets, visible, phase + errors[0], errors[1])
    own = corr[..., 0].real
    other = overlaid_power(own, offsets, visible)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio_db = 10 * np.log10(other / own)
    ratio_db = np.where(visible[None, :], ratio_db, np.nan).astype(np.float32)
    # The correlations stay each gate's own echo (a processor may recover a far trip).
    return folded, corr, ratio_db
