"""Fast time for the weather channel: what the receive chain makes of scatterers spread in range.

A truth gate of width Δ is a continuum of independent scatterers. A scatterer at range offset x
beyond a gate, moving at radial velocity v, returns the radiated pulse p(t) delayed by 2x/c and
multiplied within the pulse by exp(-j 2π (2v/λ) t) (range-Doppler coupling); the receive filter
h and the gate sampling are linear, so the gate's voltage is y_v(x) times the scatterer's
amplitude, where y_v is the filter output for a point target (the range response) at Doppler
v. Between receiver samples the response is the band-limited interpolant of its samples
(the pulse is sampled at the waveform's rate, at least twice its bandwidth).

The model is built once per run from the range response:

- **Sub-gate grid.** Each truth cell holds ``n_fine`` point scatterers on a midpoint grid about
  four times finer than the receiver's samples. Y_v[d, s] = y_v(dΔ + x_s) sqrt(Δ/n_fine) is the
  voltage that scatterer s of a cell d gates beyond an output gate puts on that gate.
- **Doppler within the pulse.** exp(-j x τ), τ = (t - t_c)/T_half in [-1, 1] along the pulse and
  x = 2π (2v/λ) T_half, is a Taylor series: Y_v = Σ_k (-j u)^k Ỹ_k with u = v / v_max and Ỹ_k
  the response of x_max^k τ^k p / k!. ``K`` orders are kept.
- **Fewest random numbers.** The stacked [Ỹ_0; ...; Ỹ_{K-1}] = U S V^H. The sub-gate
  scatterers x of a cell are independent and identically distributed, so z = V^H x are too
  (a unitary rotation), and the cell puts Σ_k (-j u)^k U_k S z on the gates around it. Only
  the ``r`` components with weight above the tolerance are drawn: the cell's degrees of
  freedom (about 2BΔ/c plus its edges), not its sub-gate count.
- **Power weights.** The expected power a cell d gates away puts on a gate is
  r_d(u) = Σ_s |Y_v[d, s]|², a polynomial in u (``power``), used by the levels that draw no
  scatterers.

``K``, ``r``, the polynomial degree and the gate offsets kept are the smallest for which every
gate-to-gate covariance a cell produces, at every velocity up to the truth's largest, is within
1 % of the exact one (the response with exp(-j x τ) itself) or below the floor (``floor_db``
from the largest).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
import xarray as xr

from ..signals import SPEED_OF_LIGHT

#: Relative error allowed on each gate-to-gate covariance a cell produces (1 %, 0.04 dB).
RELATIVE_TOLERANCE = 0.01
#: Normalised velocities at which the truncated model is checked against the exact response.
CHECK_VELOCITIES = np.linspace(-1.0, 1.0, 9)
#: Kernels this short are applied by direct sums, longer ones by FFT or blocked products.
DIRECT_TAPS = 8


@dataclass(frozen=True)
class RangeModel:
    """The receive chain's range response for the weather channel (see the module docstring).

    ``offsets`` are the gate offsets d = -pad..pad (a cell d gates beyond the output gate);
    ``power[n, q]`` gives the power weight (metres) r_d(u) = Σ_n power[n, q] u^n of offset
    d = offsets[q]; ``kernels[k, q, i]`` the voltage of component i of Doppler order k;
    ``basis`` (components x n_fine) the rows of V^H, i.e. how each drawn component is made of
    the cell's sub-gate scatterers (unit-norm rows).
    """

    gate_m: float
    offsets: np.ndarray
    power: np.ndarray
    kernels: np.ndarray
    basis: np.ndarray
    velocity_scale_ms: float
    phase_scale_rad: float

    @property
    def pad(self) -> int:
        return int(self.offsets[-1])

    @property
    def components(self) -> int:
        return int(self.kernels.shape[2])

    @property
    def orders(self) -> int:
        return int(self.kernels.shape[0])

    @property
    def total_m(self) -> float:
        """Integral of the power response over range at zero Doppler (the radar constant's)."""
        return float(self.power[0].sum())

    def weights(self, u: np.ndarray) -> np.ndarray:
        """Power weights r_d(u) (metres) for normalised velocities u: (*u.shape, offsets)."""
        u = np.asarray(u, np.float64)[..., None]
        out = np.broadcast_to(self.power[0], (*u.shape[:-1], self.power.shape[1])).copy()
        for n in range(1, self.power.shape[0]):
            out += self.power[n] * u**n
        return out

    def normalised_velocity(self, velocity_ms: np.ndarray) -> np.ndarray:
        if self.velocity_scale_ms <= 0:
            return np.zeros(np.shape(velocity_ms))
        return np.clip(np.asarray(velocity_ms) / self.velocity_scale_ms, -1.0, 1.0)


def aligned_response(response: xr.Dataset) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The radiated pulse, the filter taps, the sample spacing in range (m) and the range offset
    (m) of sample 0 of their full convolution, checked against the response's ``voltage``.

    Sample n of conv(transmitted, taps) is the gate's voltage for a point target at offset
    offset0 - n dx (a farther target arrives later and is seen earlier in the filter output).
    """
    p = response["transmitted"].values.astype(np.complex128)
    h = response["taps"].values.astype(np.complex128)
    fs = float(response.attrs["sample_rate_hz"])
    dx = SPEED_OF_LIGHT / (2 * fs)
    conv = np.convolve(p, h)
    volt = response["voltage"].values[::-1]
    off = response["offset_m"].values[::-1]
    if volt.size > 1 and not np.allclose(-np.diff(off), dx, rtol=1e-6):
        raise ValueError(
            "range_response: offset_m must step by c / (2 sample_rate_hz) = "
            f"{dx:.6g} m, the range of one sample"
        )
    # Where the voltage sits in the convolution (a filter block may trim zeros).
    lag = int(np.argmax(np.abs(np.correlate(np.abs(conv), np.abs(volt), mode="full"))))
    shift = lag - (volt.size - 1)
    lo, hi = max(0, shift), min(conv.size, shift + volt.size)
    ref = np.zeros(conv.size, complex)
    ref[lo:hi] = volt[lo - shift : hi - shift]
    scale = float(np.abs(conv).max()) or 1.0
    if np.abs(ref - conv).max() > 1e-6 * scale:
        raise ValueError(
            "range_response: 'voltage' is not the convolution of 'transmitted' with 'taps' "
            "(the filter output for a point target); the weather channel needs all three to agree"
        )
    return p, h, dx, float(off[0] + shift * dx)


def _interpolator(position: np.ndarray, length: int) -> np.ndarray:
    """Band-limited (sinc) interpolation weights at fractional sample positions.

    sinc(q - n) = (-1)^n sin(π q) / (π (q - n)): one sine per position, not per weight.
    """
    n = np.arange(length)
    diff = position[:, None] - n[None, :]
    on = np.abs(diff) < 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (np.sin(np.pi * position)[:, None] * np.where(n % 2, -1.0, 1.0)) / (np.pi * diff)
    w[on.any(axis=1)] = 0.0
    w[on] = 1.0
    return w


def range_model(
    response: xr.Dataset,
    gate_m: float,
    wavelength_m: float,
    max_velocity_ms: float,
    floor_db: float = -80.0,
    n_fine: int | None = None,
) -> RangeModel:
    """Build the weather channel's fast-time model of a range response (module docstring).

    ``max_velocity_ms`` is the largest |radial velocity| the cells have; ``n_fine`` (odd) the
    sub-gate scatterers per cell of the fine grid (default: four per receiver sample, at least
    15).
    """
    p, h, dx, offset0 = aligned_response(response)
    n_p = p.size
    half = (n_p - 1) / 2
    tau = (np.arange(n_p) - half) / half if n_p > 1 else np.zeros(1)
    x_max = 2 * np.pi * (2 * max_velocity_ms / wavelength_m) * (half * 2 * dx / SPEED_OF_LIGHT)
    conv_len = n_p + h.size - 1
    reach = max(abs(offset0), abs(offset0 - (conv_len - 1) * dx)) + dx
    pad = int(np.ceil(reach / gate_m + 0.5))
    d = np.arange(-pad, pad + 1)
    if n_fine is None:
        n_fine = max(15, int(np.ceil(4 * gate_m / dx)))
        n_fine += 1 - n_fine % 2
    x_s = (np.arange(n_fine) - (n_fine - 1) / 2) * gate_m / n_fine
    where = (offset0 - (d[:, None] * gate_m + x_s[None, :]).ravel()) / dx

    def on_grid(vectors: list[np.ndarray]) -> np.ndarray:
        """Each filter output (conv sample vector) at every (offset, sub-gate) point."""
        stack = np.stack(vectors, axis=1)
        out = np.empty((where.size, len(vectors)), complex)
        step = max(1, 2_000_000 // conv_len)  # interpolation weights a few tens of MB at most
        for a in range(0, where.size, step):
            out[a : a + step] = _interpolator(where[a : a + step], conv_len) @ stack
        out *= np.sqrt(gate_m / n_fine)
        return out.T.reshape(len(vectors), d.size, n_fine)

    # The exact responses at the check velocities, and the Taylor orders up to where the
    # remainder bound e^x x^K / K! of the series is far below the floor, interpolated together.
    us = CHECK_VELOCITIES if x_max > 0 else np.zeros(1)
    bound = 1
    while x_max > 0 and math.exp(x_max) * x_max**bound / math.factorial(bound) > 1e-9:
        bound += 1
    if bound > 40:
        raise ValueError(
            f"range_response: the Doppler shift of {max_velocity_ms:g} m/s over this pulse "
            "needs more than 40 Taylor orders"
        )
    grid = on_grid(
        [np.convolve(p * np.exp(-1j * x_max * u * tau), h) for u in us]
        + [np.convolve(p * (x_max * tau) ** k / math.factorial(k), h) for k in range(bound)]
    )
    exact, orders = grid[: us.size], grid[us.size :]
    g_exact = np.einsum("vds,ves->vde", exact, exact.conj())
    floor = 10 ** (floor_db / 10) * float(np.abs(g_exact).max())

    def close(g: np.ndarray) -> bool:
        return bool(
            np.all(np.abs(g - g_exact) <= np.maximum(RELATIVE_TOLERANCE * np.abs(g_exact), floor))
        )

    powers = (-1j * us[:, None]) ** np.arange(bound)[None, :]  # (-j u)^k
    for n_k in range(1, bound + 1):
        y = np.einsum("vk,kds->vds", powers[:, :n_k], orders[:n_k])
        if close(np.einsum("vds,ves->vde", y, y.conj())):
            break
    orders = orders[:n_k]
    u_mat, sv, vh = np.linalg.svd(orders.reshape(n_k * d.size, n_fine), full_matrices=False)
    u_k = u_mat.reshape(n_k, d.size, -1) * sv[None, None, :]
    for rank in range(1, sv.size + 1):
        a = np.einsum("vk,kdi->vdi", powers[:, :n_k], u_k[:, :, :rank])
        if close(np.einsum("vdi,vei->vde", a, a.conj())):
            break
    # Power weights: r_d(u) = Σ_{k,l} (-j u)^k (j u)^l <Ỹ_k, Ỹ_l>_d, a polynomial in u.
    cross = np.einsum("kds,lds->kld", orders, orders.conj())
    coeff = np.zeros((2 * n_k - 1, d.size))
    for k in range(n_k):
        for m in range(n_k):
            coeff[k + m] += ((-1j) ** k * (1j) ** m * cross[k, m]).real
    diag = np.einsum("vdd->vd", g_exact).real
    for degree in range(1, coeff.shape[0] + 1):
        est = (us[:, None] ** np.arange(degree)[None, :]) @ coeff[:degree]
        if np.all(np.abs(est - diag) <= np.maximum(RELATIVE_TOLERANCE * diag, floor)):
            break
    # Offsets whose power stays below the floor at every velocity are dropped (symmetrically,
    # so the output gate stays at the centre of the kernel).
    strong = np.flatnonzero(diag.max(axis=0) > floor)
    keep_pad = int(max(abs(d[strong[0]]), abs(d[strong[-1]])))
    q = slice(pad - keep_pad, pad + keep_pad + 1)
    return RangeModel(
        gate_m=float(gate_m),
        offsets=d[q],
        power=coeff[:degree, q].copy(),
        kernels=u_k[:, q, :rank].copy(),
        basis=vh[:rank].copy(),
        velocity_scale_ms=float(max_velocity_ms) if x_max > 0 else 0.0,
        phase_scale_rad=float(x_max),
    )


def range_correlate(a: np.ndarray, w: np.ndarray, n_out: int, exact: bool = False) -> np.ndarray:
    """out[g] = Σ_q Σ_c w[q, c] a[g + q, c, ...] for g < n_out (the range weighting).

    ``a`` is (n_out + Q - 1, C, *T), ``w`` is (Q, C). Short kernels are summed directly. Long
    ones by FFT, whose round-off is relative to the largest value along the ray: fine for
    voltages (1e-7 of the strongest voltage is -140 dB), not for powers, which keep their
    dynamic range with ``exact`` (blocked Toeplitz matrix products, whose zeros add nothing).
    """
    q_len, n_c = w.shape
    tail = a.shape[2:]
    flat = a.reshape(a.shape[0], n_c, -1)
    if a.dtype.kind != "c" and np.iscomplexobj(w):
        raise TypeError("complex weights need complex data")
    # Weights in the data's own precision, so float32 work is not promoted to float64.
    w = w.astype(np.result_type(a.dtype, w.dtype) if a.dtype.kind == "c" else a.dtype)
    if a.dtype == np.complex64:
        w = w.astype(np.complex64)
    if q_len <= DIRECT_TAPS:
        out = np.zeros((n_out, flat.shape[2]), np.result_type(a.dtype, w.dtype))
        for q in range(q_len):
            for c in range(n_c):
                if w[q, c] != 0:
                    out += w[q, c] * flat[q : q + n_out, c]
        return out.reshape(n_out, *tail)
    if exact:
        return _blocked_correlate(flat, w, n_out).reshape(n_out, *tail)
    n = scipy.fft.next_fast_len(flat.shape[0])
    spec = scipy.fft.fft(flat, n=n, axis=0)
    kern = scipy.fft.fft(w[::-1], n=n, axis=0).astype(spec.dtype)
    prod = (kern[:, None, :] @ spec)[:, 0, :]
    return scipy.fft.ifft(prod, axis=0, overwrite_x=True)[q_len - 1 : q_len - 1 + n_out].reshape(
        n_out, *tail
    )


def _blocked_correlate(flat: np.ndarray, w: np.ndarray, n_out: int, block: int = 32) -> np.ndarray:
    """range_correlate by blocks of output gates, each one matrix product with a Toeplitz band."""
    q_len, n_c = w.shape
    block = min(block, n_out)
    band = np.zeros((block, block + q_len - 1, n_c), w.dtype)
    for i in range(block):
        band[i, i : i + q_len] = w
    band = band.reshape(block, -1)
    out = np.empty((n_out, flat.shape[2]), np.result_type(flat.dtype, w.dtype))
    for s in range(0, n_out, block):
        nb = min(block, n_out - s)
        rows = flat[s : s + nb + q_len - 1].reshape(-1, flat.shape[2])
        out[s : s + nb] = band[:nb, : (nb + q_len - 1) * n_c] @ rows
    return out


class GateSum:
    """Gate voltages of cells drawn as range components, added batch by batch.

    Cells lie between padded gates ``first`` and ``last``; output gate g sees a cell at padded
    gate p at offset d = p - pad - g. :meth:`add` takes (z, c) terms: z (cell x component x
    pulse, unit power) times the complex factor c per cell (amplitude, polarimetric mix), so
    that the cell's voltage is Σ c z; :meth:`voltages` applies the range model once for all.
    """

    def __init__(
        self,
        model: RangeModel,
        first: int,
        last: int,
        n_out: int,
        pulses: int,
        dtype: type | np.dtype,
    ):
        self.model = model
        self.lo = max(0, first - 2 * model.pad)
        self.hi = min(n_out, last + 1)
        self.span = max(0, self.hi - self.lo) + 2 * model.pad
        n_k, _, r = model.kernels.shape
        # W[p, k, (i, m)] = Σ_{cells at p} c (-j u)^k z_i(m).
        self.w = np.zeros((self.span * n_k, r * pulses), dtype)

    def add(
        self, terms: list[tuple[np.ndarray, np.ndarray]], u: np.ndarray, padded_gate: np.ndarray
    ) -> None:
        """Add cells at ``padded_gate`` with normalised velocities ``u``."""
        import scipy.sparse

        n_k = self.model.orders
        n = padded_gate.size
        # One sparse product per term: the cells' factors and Doppler orders in the matrix.
        rows = ((padded_gate - self.lo)[:, None] * n_k + np.arange(n_k)[None, :]).ravel()
        cols = np.repeat(np.arange(n), n_k)
        doppler = (-1j * u[:, None]) ** np.arange(n_k)[None, :]
        for z, c in terms:
            matrix = scipy.sparse.csr_matrix(
                ((c[:, None] * doppler).ravel().astype(z.dtype), (rows, cols)),
                shape=(self.w.shape[0], n),
            )
            self.w += matrix @ z.reshape(n, -1)

    def voltages(self) -> tuple[int, np.ndarray]:
        """(first output gate, voltages of the output gates from there: gate x pulse)."""
        n_k, q_len, r = self.model.kernels.shape
        if self.hi <= self.lo:
            return self.lo, np.zeros((0, self.w.shape[1] // r), self.w.dtype)
        kern = self.model.kernels.transpose(1, 0, 2).reshape(q_len, n_k * r)
        w = self.w.reshape(self.span, n_k * r, -1)
        return self.lo, range_correlate(w, kern, self.hi - self.lo)
