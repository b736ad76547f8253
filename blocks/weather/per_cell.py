"""The per-cell fidelity levels, ``covariance`` (paper eq. 13-18) and ``monte_carlo``
(eq. 5-12): each cell's series drawn by its :class:`~pasim_blocks.weather.cells.CellModel`
and spread over the gates by the range response.
"""

from __future__ import annotations

import numpy as np

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
from .beams import BeamDraw, significant_cells
from .fasttime import GateSum
from .polarimetry import (
    cell_covariance,
    cholesky,
    port_channels,
)
from .spectra import (
    FLOOR,
)


def _significant(beam: BeamDraw, gg: np.ndarray, jj: np.ndarray) -> tuple[np.ndarray, ...]:
    """The cells (gate, radial) worth drawing under the beam's ``support_fraction``."""
    if beam.support_fraction <= 0 or not gg.size:
        return gg, jj
    rows = beam.near[jj]
    power = np.maximum(
        beam.cells.s_h[rows, gg] * beam.omega[0, jj], beam.cells.s_v[rows, gg] * beam.omega[1, jj]
    )
    keep = significant_cells(power, gg, beam.support_fraction)
    return gg[keep], jj[keep]


def draw_per_cell(out: np.ndarray, beam: BeamDraw) -> None:
    """Add the per-cell draws (covariance, monte_carlo, or combined's narrow cells).

    Each cell draws its independent range components, which the range model spreads over
    the gates it reaches (:class:`pasim_blocks.weather.fasttime.GateSum`).
    """
    cells, near, omega, ranges, gen_h, gen_v, need_v = beam[:7]
    if cells.per_cell is None or cells.model is None:
        return
    # Cells ordered by gate, then radial, so that each gate's sum is one segment.
    gg, jj = np.nonzero(cells.per_cell[near].T)
    gg, jj = _significant(beam, gg, jj)
    if not gg.size:
        return
    n_g, pulses = out.shape[1], out.shape[2]
    rows = near[jj]
    u = cells.u[rows, gg]
    a_h = np.sqrt(cells.s_h[rows, gg] * omega[0, jj])
    a_v = np.sqrt(cells.s_v[rows, gg] * omega[1, jj])
    sums = [GateSum(ranges, int(gg[0]), int(gg[-1]), n_g, pulses, out.dtype) for _ in out]
    # Cells in batches, so that the drawn components stay a few tens of MB.
    batch = max(1, 2_000_000 // (ranges.components * pulses))
    for a in range(0, gg.size, batch):
        c = slice(a, min(gg.size, a + batch))
        h, v = cells.model.draw(rows[c], gg[c], gen_h, gen_v, need_v, ranges.basis)
        for acc, terms, amp in ((sums[0], h, a_h), (sums[1], v, a_v)):
            if terms:
                acc.add([(z, f * amp[c]) for z, f in terms], u[c], gg[c])
    for k in range(2 if need_v else 1):
        lo, volts = sums[k].voltages()
        out[k, lo : lo + volts.shape[0]] += volts


def draw_per_cell_coupled(out: np.ndarray, beam: BeamDraw) -> None:
    """:meth:`draw_per_cell` with the coupled channels.

    Each cell's channel covariance (2 x 2 SHV, 4 x 4 AHV) is factored, L L^H = P, and
    applied to independent unit-power series of the cell's Doppler spectrum
    (:meth:`CellModel.units`): exact in distribution, since the cell's channel covariance
    does not depend on the lag. A port's series is its channel's on the pulses of that
    channel's transmit state.
    """
    cells, near, ranges = beam.cells, beam.near, beam.ranges
    if cells.per_cell is None or cells.model is None:
        return
    gg, jj = np.nonzero(cells.per_cell[near].T)
    gg, jj = _significant(beam, gg, jj)
    if not gg.size:
        return
    n_ch = beam.channels
    n_g, pulses = out.shape[1], out.shape[2]
    rows = near[jj]
    u = cells.u[rows, gg]
    assert beam.coupling is not None  # the coupled draw is only made with a coupling
    cov = cell_covariance(beam.coupling.select(n_ch)[:, :, jj], cells.sources(rows, gg))
    factor = cholesky(cov, n_ch, FLOOR[np.float64]).astype(out.dtype)
    ports = port_channels(beam.mode)[: 2 if n_ch > 1 else 1]
    sums = [GateSum(ranges, int(gg[0]), int(gg[-1]), n_g, pulses, out.dtype) for _ in ports]
    batch = max(1, 2_000_000 // (ranges.components * pulses * max(1, n_ch // 2)))
    for a in range(0, gg.size, batch):
        c = slice(a, min(gg.size, a + batch))
        z = cells.model.units(rows[c], gg[c], beam.gen_h, beam.gen_v, n_ch, ranges.basis)
        for acc, (even, odd) in zip(sums, ports, strict=True):
            if even == odd:
                terms = [(z[i], factor[even, i, c]) for i in range(even + 1)]
            else:
                # Each pulse's mix of the unit series is its transmit state's channel.
                mix = np.zeros_like(z[0])
                for parity, k in ((0, even), (1, odd)):
                    for i in range(k + 1 if k < n_ch else 0):
                        mix[..., parity::2] += factor[k, i, c][:, None, None] * z[i][..., parity::2]
                terms = [(mix, np.ones(mix.shape[0], out.dtype))]
            acc.add([t for t in terms if t[1].any()], u[c], gg[c])
    for k, acc in enumerate(sums):
        lo, volts = acc.voltages()
        out[k, lo : lo + volts.shape[0]] += volts
