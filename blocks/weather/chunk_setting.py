"""What the weather channel's steps share for one chunk (:class:`ChunkSetting`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ChunkSetting:
    """What every beam of a chunk shares: the radar's and the truth's geometry, the channels
    drawn and the radar equation's constant (made by the weather channel, read by its steps)."""

    method: str
    dtype: type
    lam: float  # wavelength (m)
    prt: float  # the drawing grid's step (s): the PRT, or a staggered scan's unit u
    prt_t1: float  # the scan's (first) PRT (s)
    pulses: int  # pulses on the drawing grid
    staggered: tuple[float, np.ndarray] | None  # u and the pulses' indices on the grid
    rng_m: np.ndarray  # the truth's gate ranges
    gate_m: float
    width_deg: float  # the truth's radial width
    az_truth: np.ndarray
    dual: bool  # the truth is dual-polarisation
    mode: str  # transmission: shv or ahv
    beta: float  # transmit differential phase (deg)
    need_v: bool  # the V channel is drawn
    coupled: bool  # H and V coupled through complex co- and cross-polar fields
    k0: float  # the radar equation's constant (W per sr m of truth power)
    volume: bool  # a volume truth
    drawn: int  # receive channels drawn (0 at the expected level)
