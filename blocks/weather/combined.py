"""The ``combined`` fidelity level: each gate's series drawn at once from the weighted sum of
its cells' spectra (a 2M circulant embedding), plus the per-cell tones too narrow for it.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
from .beams import BeamDraw
from .fasttime import range_correlate
from .polarimetry import (
    cell_covariance,
    cholesky,
    pairs,
    port_channels,
)
from .spectra import (
    FLOOR,
    complex_normal,
)


def gate_spectra(
    beam: BeamDraw, products: list[np.ndarray], gsel: np.ndarray, n_g: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """Sum the cells' embedded spectra per output gate with real weights per product.

    ``products`` are radial x gate weights (for the gates ``gsel`` that hold wide cells),
    scaled to order one; each is summed per padded gate (times u^n, one set per term of
    the range power polynomial), then over the range response. Returns the output gates
    reached and their spectra (gate x product x N), or None.
    """
    cells, near, ranges = beam.cells, beam.near, beam.ranges
    dtype = cells.dtype
    n = cells.spectra.shape[1]
    pad, terms = ranges.pad, ranges.power.shape[0]
    u = cells.u[near][:, gsel]
    stacked = [p * u**k if k else p for k in range(terms) for p in products]
    weights: np.ndarray = np.stack(stacked).transpose(2, 0, 1).astype(dtype)  # g x TP x J
    code = cells.code[near][:, gsel].T  # g x J
    n_p = len(products)
    combined = np.zeros((n_g + 2 * pad, terms * n_p, n), dtype)
    # Gates in blocks so the gathered spectra (gates x radials x N) stay a few tens of MB.
    step = max(1, 4_000_000 // (near.size * n))
    for a in range(0, gsel.size, step):
        b = min(gsel.size, a + step)
        combined[gsel[a:b]] = weights[a:b] @ cells.spectra[code[a:b]]
    # Only output gates that some echo gate reaches through the range response.
    lo, hi = max(0, gsel[0] - 2 * pad), min(n_g, gsel[-1] + 1)
    s = range_correlate(
        combined[lo : hi + 2 * pad].reshape(hi - lo + 2 * pad, terms, n_p * n),
        ranges.power.T,
        hi - lo,
        exact=True,
    ).reshape(hi - lo, n_p, n)
    gates = lo + np.flatnonzero(s[:, 0].max(axis=1) > 0)
    if not gates.size:
        return None
    return gates, s[gates - lo]


def draw_combined(out: np.ndarray, beam: BeamDraw) -> None:
    """Add each gate's series drawn from its combined spectral matrix (circulant embedding).

    The spectra of the cells are summed per padded gate with the pattern weights (times
    u^n, one set per term of the range power polynomial), then over the range response.
    """
    cells, near, omega, _, gen_h, gen_v, need_v = beam[:7]
    n_g, pulses = out.shape[1], out.shape[2]
    dtype = cells.dtype
    n = cells.spectra.shape[1]
    wide = cells.wide[near]
    gsel = np.flatnonzero(wide.any(axis=0))
    if not gsel.size:
        return
    # Powers are scaled to order one, so float32 keeps 100 dB of dynamic range without
    # subnormals; the scale goes back on the voltages at the end.
    w_h = omega[0][:, None] * np.where(wide, cells.s_h[near], 0.0)
    scale = float(w_h.max()) or 1.0
    products = [w_h / scale]
    if need_v:
        products.append(omega[1][:, None] * np.where(wide, cells.s_v[near], 0.0) / scale)
        x = np.sqrt(omega[0] * omega[1])[:, None] * np.where(wide, cells.cross[near], 0) / scale
        products += [x.real, x.imag]
    summed = gate_spectra(beam, [p[:, gsel] for p in products], gsel, n_g)
    if summed is None:
        return
    gates, s = summed
    # sqrt(N) ifft(.)[:M] has covariance c[m - n] (see embedded_spectra); sqrt(N) and the
    # power scale go on the factors before the FFT.
    s *= dtype(scale * n)
    s_hh = np.maximum(s[:, 0], 0)
    l11 = np.sqrt(s_hh)
    z1 = complex_normal(gen_h, s_hh.shape, dtype)
    # This level runs first on a zeroed beam: assign, the other paths add.
    out[0, gates] = scipy.fft.ifft(l11 * z1, axis=-1, overwrite_x=True)[:, :pulses]
    if not need_v:
        return
    inv = np.divide(1, l11, out=np.zeros_like(l11), where=l11 > 0)
    l21 = (s[:, 2] * inv) + 1j * (s[:, 3] * inv)
    l22 = np.sqrt(np.maximum(np.maximum(s[:, 1], 0) - (l21.real**2 + l21.imag**2), 0))
    z2 = complex_normal(gen_v, s_hh.shape, dtype)
    out[1, gates] = scipy.fft.ifft(l21 * z1 + l22 * z2, axis=-1, overwrite_x=True)[:, :pulses]


def draw_combined_coupled(out: np.ndarray, beam: BeamDraw) -> None:
    """:meth:`draw_combined` with the coupled channels: an n x n spectral matrix per bin.

    SHV draws the two ports (2 x 2); AHV the stacked process of both transmit states,
    co-polar and cross-polar channels (4 x 4), and each pulse keeps its state's pair.
    """
    cells, near = beam.cells, beam.near
    n_ch, gen_h, gen_v = beam.channels, beam.gen_h, beam.gen_v
    n_g, pulses = out.shape[1], out.shape[2]
    dtype = cells.dtype
    n = cells.spectra.shape[1]
    wide = cells.wide[near]
    gsel = np.flatnonzero(wide.any(axis=0))
    if not gsel.size:
        return
    src = [np.where(wide[:, gsel], a[:, gsel], 0) for a in cells.sources(near)]
    assert beam.coupling is not None  # the coupled draw is only made with a coupling
    cov = cell_covariance(beam.coupling.select(n_ch)[..., None], src)  # pair x J x g
    scale = float(cov[0].real.max()) or 1.0
    plist = pairs(n_ch)
    products = []
    for p, (k, q) in enumerate(plist):
        products += [cov[p].real / scale] + ([cov[p].imag / scale] if k != q else [])
    summed = gate_spectra(beam, products, gsel, n_g)
    if summed is None:
        return
    gates, s = summed
    s *= dtype(scale * n)
    spectra = np.empty((len(plist), *s[:, 0].shape), np.result_type(dtype, np.complex64))
    i = 0
    for p, (k, q) in enumerate(plist):
        spectra[p] = s[:, i] if k == q else s[:, i] + 1j * s[:, i + 1]
        i += 1 if k == q else 2
    factor = cholesky(spectra, n_ch, FLOOR[dtype])
    z = [complex_normal(gen_h if k == 0 else gen_v, s[:, 0].shape, dtype) for k in range(n_ch)]
    series = [
        scipy.fft.ifft(sum(factor[k, i] * z[i] for i in range(k + 1)), axis=-1, overwrite_x=True)[
            :, :pulses
        ]
        for k in range(n_ch)
    ]
    # This level runs first on a zeroed beam: assign, the other paths add.
    for q, (even, odd) in enumerate(port_channels(beam.mode)[: 2 if n_ch > 1 else 1]):
        if even == odd:
            out[q, gates] = series[even]
            continue
        for parity, k in ((0, even), (1, odd)):
            if k < n_ch:
                out[q, gates, parity::2] = series[k][:, parity::2]


def draw_tones(out: np.ndarray, beam: BeamDraw) -> None:
    """Add the zero-width cells: one random tone per output gate and velocity (exact)."""
    cells, near, omega, ranges, gen_h, gen_v, need_v = beam[:7]
    jj, gg = np.nonzero(cells.tone[near])
    if not jj.size:
        return
    n_g, pad = out.shape[1], ranges.pad
    rows = near[jj]
    code = cells.tone_code[rows, gg]
    w = [omega[0][jj] * cells.s_h[rows, gg]]
    if need_v:
        x = np.sqrt(omega[0][jj] * omega[1][jj]) * cells.cross[rows, gg]
        w += [omega[1][jj] * cells.s_v[rows, gg], x.real, x.imag]
    # Each cell reaches output gate g = gate - pad - d with weight r_d(u) (its velocity's).
    offsets = ranges.offsets
    gate = (gg[None, :] - pad - offsets[:, None]).ravel()
    keys = np.tile(code, offsets.size)
    r = ranges.weights(cells.u[rows, gg]).T.ravel()  # offset-major, like gate
    ok = (gate >= 0) & (gate < n_g) & (r > 0)
    n_codes = cells.tone_velocities.size
    uniq, inv = np.unique((gate * n_codes + keys)[ok], return_inverse=True)
    tot = [np.bincount(inv, weights=(r * np.tile(c, offsets.size))[ok]) for c in w]
    g_u, c_u = uniq // n_codes, uniq % n_codes
    z1 = complex_normal(gen_h, (uniq.size,), np.float64)
    a_h = np.sqrt(np.maximum(tot[0], 0)) * z1
    # Keys sort by gate first: each gate's tones are one segment to sum.
    starts = np.flatnonzero(np.diff(g_u, prepend=-1))
    gates = g_u[starts]
    out[0, gates] += np.add.reduceat(a_h[:, None] * cells.tones[c_u], starts, axis=0)
    if need_v:
        root = np.sqrt(np.maximum(tot[0], 0))
        inv_h = np.divide(1, root, out=np.zeros_like(root), where=root > 0)
        l21 = (tot[2] + 1j * tot[3]) * inv_h
        l22 = np.sqrt(np.maximum(tot[1] - np.abs(l21) ** 2, 0))
        a_v = l21 * z1 + l22 * complex_normal(gen_v, (uniq.size,), np.float64)
        out[1, gates] += np.add.reduceat(a_v[:, None] * cells.tones[c_u], starts, axis=0)


def draw_tones_coupled(out: np.ndarray, beam: BeamDraw) -> None:
    """:meth:`draw_tones` with the coupled channels (n x n factor per gate and velocity)."""
    cells, near, ranges = beam.cells, beam.near, beam.ranges
    n_ch = beam.channels
    jj, gg = np.nonzero(cells.tone[near])
    if not jj.size:
        return
    n_g, pad = out.shape[1], ranges.pad
    rows = near[jj]
    code = cells.tone_code[rows, gg]
    assert beam.coupling is not None  # the coupled draw is only made with a coupling
    cov = cell_covariance(beam.coupling.select(n_ch)[:, :, jj], cells.sources(rows, gg))
    plist = pairs(n_ch)
    w: list[np.ndarray] = []
    for p, (k, q) in enumerate(plist):
        w += [cov[p].real] + ([cov[p].imag] if k != q else [])
    offsets = ranges.offsets
    gate = (gg[None, :] - pad - offsets[:, None]).ravel()
    keys = np.tile(code, offsets.size)
    r = ranges.weights(cells.u[rows, gg]).T.ravel()  # offset-major, like gate
    ok = (gate >= 0) & (gate < n_g) & (r > 0)
    n_codes = cells.tone_velocities.size
    uniq, inv = np.unique((gate * n_codes + keys)[ok], return_inverse=True)
    tot = [np.bincount(inv, weights=(r * np.tile(c, offsets.size))[ok]) for c in w]
    totals = np.empty((len(plist), uniq.size), np.complex128)
    i = 0
    for p, (k, q) in enumerate(plist):
        totals[p] = tot[i] if k == q else tot[i] + 1j * tot[i + 1]
        i += 1 if k == q else 2
    factor = cholesky(totals, n_ch, FLOOR[np.float64])
    z = [complex_normal(beam.gen_h, (uniq.size,), np.float64)]
    z += [complex_normal(beam.gen_v, (uniq.size,), np.float64) for _ in range(1, n_ch)]
    amplitude = [sum(factor[k, i] * z[i] for i in range(k + 1)) for k in range(n_ch)]
    g_u, c_u = uniq // n_codes, uniq % n_codes
    starts = np.flatnonzero(np.diff(g_u, prepend=-1))
    gates = g_u[starts]
    tones = cells.tones[c_u]
    for q, (even, odd) in enumerate(port_channels(beam.mode)[: 2 if n_ch > 1 else 1]):
        for parity, k in ((slice(None), even),) if even == odd else ((0, even), (1, odd)):
            if k >= n_ch:
                continue
            step = parity if isinstance(parity, slice) else slice(parity, None, 2)
            out[q, gates, step] += np.add.reduceat(
                amplitude[k][:, None] * tones[:, step], starts, axis=0
            )
