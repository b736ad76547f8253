"""Channel electronics of a phased array: errors, failures and quantised control.

Each radiating channel (an element of a planar array, a column of a cylindrical one) is fed by
one T/R module with an H and a V channel. A channel's complex weight is the commanded taper
amplitude and steering phase, as its attenuator and phase shifter can realise them, times its
random complex gain error; a failed module radiates and receives nothing on either port. The
same weight serves transmission and reception (the paper's beamforming-level model).

* Amplitude and phase errors: Gaussian, zero mean, ``amplitude_error_db`` rms in dB (a
  log-normal gain) and ``phase_error_deg`` rms, drawn independently per channel and port.
* Failures: each module fails with ``failure_probability`` (both ports together).
* Phase shifters of ``phase_bits`` bits realise the nearest multiple of ``2 pi / 2^bits``
  (rms error ``2 pi / (2^bits sqrt 12)`` when the commanded phases are spread uniformly). With
  ``randomize_quantization`` each channel has a known random insertion phase that the
  controller subtracts before quantising, so the errors of a regular phase progression are
  decorrelated instead of periodic (no quantisation lobes).
* Attenuators of ``attenuator_bits`` bits, ``attenuator_lsb_db`` per step, realise the taper
  amplitude to the nearest step below the largest weight, up to their range.

Draws are made in one fixed order from one generator, so the same seed gives the same array
whichever impairments are switched on.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

#: Marks the array's random draw among the generators of a run (beams use small integers).
_ARRAY_STREAM = 0x41525241  # "ARRA"

#: Block parameters of the channel model, with the values that make the array ideal.
IDEAL = {
    "amplitude_error_db": 0.0,
    "phase_error_deg": 0.0,
    "failure_probability": 0.0,
    "phase_bits": 0,
    "attenuator_bits": 0,
    "randomize_quantization": False,
}


class ChannelDraw(NamedTuple):
    """One realisation of the random part of the channels.

    Attributes
    ----------
    gain : ndarray
        Complex gain error per port and channel, shape ``(2, *channels)``; 0 for failed modules.
    offset : ndarray
        Random insertion phase per port and channel (rad), used by randomised quantisation.
    """

    gain: NDArray[np.complex128]
    offset: NDArray[np.float64]


def array_rng(seed: int, block_name: str, errors_seed: int | None) -> np.random.Generator:
    """The generator of an array's channel errors: from ``errors_seed`` when given (a fixed,
    built array), otherwise from the run seed and the block name (as ``pasim run --seed``)."""
    if errors_seed is not None:
        return np.random.default_rng(np.random.SeedSequence([int(errors_seed), _ARRAY_STREAM]))
    key = zlib.crc32(block_name.encode())
    return np.random.default_rng(np.random.SeedSequence([int(seed), key, _ARRAY_STREAM]))


@dataclass(frozen=True)
class ChannelModel:
    """The electronics behind every channel of an array (see the module docstring)."""

    amplitude_error_db: float = 0.0
    phase_error_deg: float = 0.0
    failure_probability: float = 0.0
    phase_bits: int = 0
    attenuator_bits: int = 0
    attenuator_lsb_db: float = 0.5
    randomize_quantization: bool = False

    @classmethod
    def from_params(cls, p: dict[str, Any]) -> ChannelModel:
        return cls(
            amplitude_error_db=float(p["amplitude_error_db"]),
            phase_error_deg=float(p["phase_error_deg"]),
            failure_probability=float(p["failure_probability"]),
            phase_bits=int(p["phase_bits"]),
            attenuator_bits=int(p["attenuator_bits"]),
            attenuator_lsb_db=float(p["attenuator_lsb_db"]),
            randomize_quantization=bool(p["randomize_quantization"]),
        )

    @property
    def random(self) -> bool:
        """True when the weights depend on a random draw (not only on the steering)."""
        return bool(
            self.amplitude_error_db > 0
            or self.phase_error_deg > 0
            or self.failure_probability > 0
            or (self.phase_bits > 0 and self.randomize_quantization)
        )

    @property
    def ideal(self) -> bool:
        """True when every channel realises its commanded weight exactly."""
        return not self.random and self.phase_bits == 0 and self.attenuator_bits == 0

    def draw(self, channels: tuple[int, ...], rng: np.random.Generator) -> ChannelDraw:
        """Draw the errors of every channel (``channels`` is the array's channel grid shape)."""
        shape = (2, *channels)
        # Always the same four draws in the same order: same seed, same array.
        amplitude = rng.standard_normal(shape)
        phase = rng.standard_normal(shape)
        alive = rng.uniform(size=channels) >= self.failure_probability
        offset = rng.uniform(0.0, 2.0 * np.pi, shape)
        gain = 10 ** (self.amplitude_error_db * amplitude / 20) * np.exp(
            1j * np.deg2rad(self.phase_error_deg) * phase
        )
        return ChannelDraw(gain * alive, offset)

    def quantise_phase(self, phase: NDArray, offset: NDArray | None) -> NDArray:
        """Phase a ``phase_bits`` shifter realises for commanded ``phase`` (rad)."""
        if self.phase_bits <= 0:
            return phase
        step = 2.0 * np.pi / 2**self.phase_bits
        if self.randomize_quantization and offset is not None:
            return np.round((phase - offset) / step) * step + offset
        return np.round(phase / step) * step

    def quantise_amplitude(self, taper: NDArray) -> NDArray:
        """Amplitude an ``attenuator_bits`` attenuator realises for the commanded ``taper``."""
        if self.attenuator_bits <= 0:
            return taper
        peak = np.max(np.abs(taper))
        with np.errstate(divide="ignore"):
            attenuation = -20 * np.log10(np.abs(taper) / peak)
        deepest = (2**self.attenuator_bits - 1) * self.attenuator_lsb_db
        steps = np.round(np.minimum(attenuation, deepest) / self.attenuator_lsb_db)
        return np.where(taper > 0, peak * 10 ** (-steps * self.attenuator_lsb_db / 20), 0.0)

    def weights(
        self, taper: NDArray, phase: NDArray, draw: ChannelDraw | None, port: int
    ) -> NDArray[np.complex128]:
        """Realised complex weights of one port: quantised taper and phase, times the errors.

        ``taper`` and ``phase`` are the commanded amplitude and steering phase (rad) of the
        channels, ``draw`` the array's errors (None: no random part), ``port`` 0 (H) or 1 (V).
        """
        offset = None if draw is None else draw.offset[port]
        w = self.quantise_amplitude(taper) * np.exp(1j * self.quantise_phase(phase, offset))
        if draw is not None:
            w = w * draw.gain[port]
        return np.asarray(w, dtype=np.complex128)
