"""Gaussian Doppler spectra and their colouring: the numerical kernels of the weather
channel's draws (ACF factors, circulant embedding, complex normal series).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.fft

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.

JITTER = 1e-6

# A channel's residual variance below this fraction of its own, in a Cholesky factor of a
# channel covariance, is round-off of a rank-deficient matrix (a cross-polar channel
# proportional to a co-polar one) and is taken as zero (float32 sums keep about 7 digits).
FLOOR: dict[Any, float] = {np.float32: 1e-5, np.float64: 1e-10}


def gaussian_acf_factors(
    width_ms: np.ndarray, prt_s: float, wavelength_m: float, pulses: int, dtype: type = np.float32
) -> np.ndarray:
    """Cholesky factors of the normalised pulse-to-pulse covariance (paper eq. 13), per cell.

    R[m, n] = exp(-8 (pi w (m - n) T / lambda)^2), real and Toeplitz; the mean velocity enters
    separately as a diagonal phase, since C = D R D^H with D = diag(exp(-j 4 pi v m T/lambda)).
    """
    m = np.arange(pulses)
    lag = (m[:, None] - m[None, :]).astype(np.float64)
    a = (np.pi * prt_s / wavelength_m) ** 2
    cov = np.exp(-8.0 * a * width_ms[:, None, None] ** 2 * lag[None] ** 2)
    cov += JITTER * np.eye(pulses)
    factors = np.linalg.cholesky(cov)
    # Entries this small change nothing, but as float32 subnormals they slow every product
    # with them a hundredfold.
    factors[np.abs(factors) < 1e-20] = 0.0
    return factors.astype(dtype)


class FactorCache:
    """Cholesky factors of eq. 13 per distinct spectrum width, shared by cells and beams.

    Level-II widths come in 0.5 m/s steps, so a sweep holds a few dozen distinct values: one
    factorisation per value is exact and replaces one per cell. Factors are computed the first
    time a width is needed.
    """

    def __init__(
        self,
        widths_ms: np.ndarray,
        shape: tuple[int, ...],
        prt_s: float,
        wavelength_m: float,
        pulses: int,
        dtype: type = np.float32,
    ):
        #: The distinct widths, ascending; ``code`` is each cell's index into them (-1 for a
        #: cell without echo), filled by the owner (:class:`~pasim_blocks.weather.cells.
        #: TruthCells`) as it prepares its cells.
        self.widths = widths_ms
        self.code = np.full(shape, -1, np.int64)
        self.args = (prt_s, wavelength_m, pulses)
        self.dtype = dtype
        self.factors: dict[int, np.ndarray] = {}

    def colour(self, codes: np.ndarray, gen: np.random.Generator) -> np.ndarray:
        """Draw coloured sequences for cells with width codes ``codes``: (cell, 2, pulse).

        Cells are drawn grouped by width so each group is one matrix product on contiguous
        memory; the two rows per cell are the real and imaginary parts of one complex sequence.
        """
        pulses = self.args[2]
        order = np.argsort(codes, kind="stable")
        sorted_codes = codes[order]
        bounds = np.flatnonzero(np.diff(sorted_codes)) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [codes.size]])
        missing = [int(c) for c in sorted_codes[starts] if int(c) not in self.factors]
        if missing:
            new = gaussian_acf_factors(self.widths[missing], *self.args, self.dtype)
            self.factors.update(zip(missing, new, strict=True))
        white = gen.standard_normal((codes.size, 2, pulses), dtype=self.dtype)
        out = np.empty_like(white)
        for a, b in zip(starts, stops, strict=True):
            factor = self.factors[int(sorted_codes[a])]
            out[a:b] = (white[a:b].reshape(-1, pulses) @ factor.T).reshape(b - a, 2, pulses)
        # Back to the callers' cell order.
        result = np.empty_like(out)
        result[order] = out
        return result


def embedding_size(
    width_ms: np.ndarray, prt_s: float, wavelength_m: float, pulses: int, dtype: type
) -> int:
    """Smallest even circulant size N <= 2M whose embedding reproduces lags 0..M-1.

    A circulant of size N reproduces r(d) for d <= N/2 and gives r(N - d)* for larger d, so it
    is exact up to the tail once |r| is negligible beyond lag L and N >= max(2L, M + L - 1).
    Negligible means below the working precision (1e-7 for float32, 1e-15 for float64), so the
    narrowest spectrum sets L and float64 keeps N = 2M for all but wide spectra.
    """
    tol = 1e-7 if dtype == np.float32 else 1e-15
    a = np.pi * prt_s / wavelength_m
    w = float(np.min(width_ms)) if width_ms.size else 0.0
    if w <= 0:
        return 2 * pulses
    # exp(-8 (a w L)^2) < tol
    lag = int(np.ceil(np.sqrt(-np.log(tol) / 8) / (a * w)))
    n = max(2 * lag, pulses + lag - 1)
    # A length with small prime factors: an FFT of 94 = 2 x 47 is three times slower than 96.
    n = scipy.fft.next_fast_len(n + n % 2)
    while n % 2:
        n = scipy.fft.next_fast_len(n + 1)
    return int(min(2 * pulses, n))


def embedded_spectra(
    velocity_ms: np.ndarray,
    width_ms: np.ndarray,
    prt_s: float,
    wavelength_m: float,
    pulses: int,
    dtype: type,
    n: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues of the circulant embedding of each cell's normalised autocorrelation.

    r(l) = exp(-8 (pi w l T / lambda)^2) exp(-j 4 pi v l T / lambda) is placed in the first
    column of a Hermitian circulant of size N (default 2M): c[l] = r(l) for l < N/2,
    c[N/2] = Re r(N/2), c[N-l] = r(l)*. With N = 2M its top-left M x M block is the Toeplitz
    covariance of eq. 13 exactly (see :func:`embedding_size` for smaller N), so drawing from
    the circulant and keeping M samples is exact when every eigenvalue is non-negative.
    Returns the eigenvalues (cells x N, real) and a flag per cell that is True when the
    embedding is not positive semi-definite (spectra too narrow to decay: width 0, or a few
    tenths of a m/s at long PRTs); such cells need their own path.
    """
    n = 2 * pulses if n is None else n
    half = n // 2
    lag = np.arange(half + 1, dtype=np.float64)
    a = np.pi * prt_s / wavelength_m
    r = np.exp(-8.0 * (a * width_ms[:, None] * lag) ** 2) * np.exp(
        -4j * a * velocity_ms[:, None] * lag
    )
    c = np.zeros((velocity_ms.size, n), np.complex128)
    c[:, :half] = r[:, :half]
    c[:, half] = r[:, half].real
    c[:, half + 1 :] = np.conj(r[:, half - 1 : 0 : -1])
    lam = np.fft.fft(c, axis=1).real
    peak = lam.max(axis=1, keepdims=True)
    narrow = (lam.min(axis=1) < -1e-6 * peak[:, 0]) | (width_ms <= 0)
    # Round-off below the working precision; left in, float32 subnormals slow the sums.
    tiny = 1e-12 if dtype == np.float32 else 1e-30
    lam = np.where(lam > tiny * peak, lam, 0.0)
    return lam.astype(dtype), narrow


def phasor(phase: np.ndarray) -> np.ndarray:
    """exp(j phase), from cos and sin (a complex exp of a real argument costs twice as much)."""
    out = np.empty(phase.shape, np.complex128)
    out.real = np.cos(phase)
    out.imag = np.sin(phase)
    return out


def complex_normal(gen: np.random.Generator, shape: tuple[int, ...], dtype: type) -> np.ndarray:
    """Circular complex Gaussian deviates with E|z|^2 = 1."""
    # Real and imaginary parts drawn side by side and viewed as complex: no copies.
    w = gen.standard_normal((*shape[:-1], 2 * shape[-1]), dtype=dtype)
    w *= dtype(np.sqrt(0.5))
    return w.view(np.complex64 if dtype == np.float32 else np.complex128)
