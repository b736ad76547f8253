"""The weather channel: truth cells -> dual-polarisation echo time series at every gate."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, NamedTuple

import numpy as np
import scipy.fft
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from .angles import circular_difference
from .fasttime import GateSum, RangeModel, range_correlate, range_model
from .polarimetry import (
    CONJUGATE_SOURCES,
    MODES,
    SOURCE_COMPONENTS,
    cell_covariance,
    channel_rows,
    cholesky,
    pairs,
    port_channels,
    receive_channels,
)
from .signals import (
    BEAMS,
    CALIBRATION,
    CORRELATION_PRODUCTS,
    ECHO_CORRELATIONS,
    IQ,
    KW2,
    PATTERN,
    POLARIMETRIC_FIELDS,
    POLARIZATIONS,
    RANGE_RESPONSE,
    SHV_PRODUCTS,
    SIGNAL_POWER,
    SPEED_OF_LIGHT,
    TRUTH,
)

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
FILL = {"VRADH": 0.0, "WRADH": 1.0, "ZDR": 0.0, "RHOHV": 0.99, "PHIDP": 0.0}

# Added to the diagonal of each normalised covariance so that narrow spectra (width 0 makes it
# rank one) still factor in float64; it is a white component 60 dB below the signal.
JITTER = 1e-6

# A channel's residual variance below this fraction of its own, in a Cholesky factor of a
# channel covariance, is round-off of a rank-deficient matrix (a cross-polar channel
# proportional to a co-polar one) and is taken as zero (float32 sums keep about 7 digits).
FLOOR = {np.float32: 1e-5, np.float64: 1e-10}

#: Fidelity levels of the weather channel, fastest first.
METHODS = ("expected", "combined", "covariance", "monte_carlo")


def azimuth_profile(power: np.ndarray, d_el_deg: np.ndarray, elevation_deg: float) -> np.ndarray:
    """Two-way pattern integrated over elevation (rad), per polarisation and azimuth offset."""
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))
    step = np.deg2rad(d_el_deg[1] - d_el_deg[0])
    p = power.astype(np.float64)
    p *= p
    return np.einsum("e,pea->pa", cos_el, p) * step


def cell_solid_angles(
    profile: np.ndarray, d_az_deg: np.ndarray, centre_deg: np.ndarray, width_deg: float
) -> np.ndarray:
    """Two-way pattern integral over each truth radial's azimuth extent (sr), per polarisation."""
    step = np.deg2rad(d_az_deg[1] - d_az_deg[0])
    edges = np.concatenate(
        [
            d_az_deg - (d_az_deg[1] - d_az_deg[0]) / 2,
            [d_az_deg[-1] + (d_az_deg[1] - d_az_deg[0]) / 2],
        ]
    )
    out = np.empty((profile.shape[0], centre_deg.size))
    for i in range(profile.shape[0]):
        cum = np.concatenate([[0.0], np.cumsum(profile[i] * step)])
        out[i] = np.interp(centre_deg + width_deg / 2, edges, cum) - np.interp(
            centre_deg - width_deg / 2, edges, cum
        )
    return out


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
        width_ms: np.ndarray,
        echo: np.ndarray,
        prt_s: float,
        wavelength_m: float,
        pulses: int,
        dtype: type = np.float32,
    ):
        self.widths, codes = np.unique(width_ms[echo], return_inverse=True)
        self.code = np.full(echo.shape, -1, np.int64)
        self.code[echo] = codes.ravel()
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


class CellModel:
    """Unit-power H and V slow-time series of truth cells, by one of the paper's two methods.

    ``draw(rows, gates, gen_h, gen_v, need_v, basis)`` returns H and V as lists of terms
    (series, factor per cell), the channel being Σ factor x series; each series is cell x
    component x pulse: the cell's ``r`` independent range components (``basis``, r x n_fine:
    how each is made of the cell's sub-gate scatterers, see :mod:`pasim_blocks.fasttime`), with
    E|h|^2 = 1 and E|v|^2 = 1 (powers, pattern and range weights are applied by the caller).
    H is drawn from ``gen_h`` only, so it is the same whether or not V is asked for:

    - ``covariance`` (eq. 13-18): V1, V2 coloured with the Cholesky factor of the Gaussian
      autocorrelation, h = V1, v = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP), per component
      (a unitary rotation of independent sub-gate scatterers leaves them independent).
    - ``monte_carlo`` (eq. 5-12): ``drops`` equal drops per cell at random positions (uniform
      phase, and a uniform place among the cell's sub-gate scatterers, which sets what each
      range component receives from it), each with its own radial velocity drawn from N(mean
      velocity, width^2) and moved every PRT; random backscatter phases with sigma_h = sigma_v
      = sigma / sqrt(2), sigma = sqrt(-2 ln rho_hv), give rho_hv = exp(-sigma^2 / 2).
    """

    def __init__(
        self,
        method: str,
        field: dict[str, np.ndarray],
        rho: np.ndarray,
        echo: np.ndarray,
        prt_s: float,
        wavelength_m: float,
        pulses: int,
        drops: int,
        dtype: type = np.float32,
    ):
        self.method = method
        self.field = field
        self.rho = rho
        self.prt_s, self.wavelength_m, self.pulses, self.drops = prt_s, wavelength_m, pulses, drops
        self.dtype = dtype
        self.cdtype = np.complex64 if dtype == np.float32 else np.complex128
        self.phase_dp = np.exp(1j * np.deg2rad(field["PHIDP"]))
        if method != "monte_carlo":
            self.factors = FactorCache(
                np.clip(field["WRADH"], 0, None), echo, prt_s, wavelength_m, pulses, dtype
            )

    def draw(
        self,
        rows: np.ndarray,
        gates: np.ndarray,
        gen_h: np.random.Generator,
        gen_v: np.random.Generator,
        need_v: bool,
        basis: np.ndarray,
    ) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[tuple[np.ndarray, np.ndarray]]]:
        """The H and V series as (series, factor per cell) terms: h = Σ factor x series."""
        if self.method == "monte_carlo":
            return self._drops(rows, gates, gen_h, gen_v, need_v, basis)
        series = self._series(rows, gates, basis.shape[0])
        x1 = series(gen_h)
        ones = np.ones(rows.size, self.cdtype)
        if not need_v:
            return [(x1, ones)], []
        x2 = series(gen_v)
        rho = self.rho[rows, gates]
        phase = self.phase_dp[rows, gates]
        # v = [rho x1 + sqrt(1 - rho^2) x2] exp(j phi_DP), as factors on x1 and x2.
        return [(x1, ones)], [(x1, rho * phase), (x2, np.sqrt(1 - rho**2) * phase)]

    def _series(self, rows: np.ndarray, gates: np.ndarray, components: int) -> Any:
        """A drawer of unit-power series (cell x component x pulse) with the cells' Doppler
        spectrum: coloured white sequences from a given generator, shifted to each cell's
        velocity."""
        n, m = rows.size, np.arange(self.pulses)[None, :]
        # sqrt(1/2): the white sequences have unit variance per real component.
        doppler = (
            np.exp(
                (-4j * np.pi * self.prt_s / self.wavelength_m)
                * (self.field["VRADH"][rows, gates][:, None] * m)
            )
            * np.sqrt(0.5)
        ).astype(self.cdtype)[:, None, :]
        codes = np.repeat(self.factors.code[rows, gates], components)

        def series(gen: np.random.Generator) -> np.ndarray:
            return self._complex(self.factors.colour(codes, gen), n, components) * doppler

        return series

    def units(
        self,
        rows: np.ndarray,
        gates: np.ndarray,
        gen_h: np.random.Generator,
        gen_v: np.random.Generator,
        count: int,
        basis: np.ndarray,
    ) -> list[np.ndarray]:
        """``count`` independent unit-power series with the cells' Doppler spectrum.

        Each is cell x component x pulse; the first comes from ``gen_h``, the others from
        ``gen_v``. A cell's received channels are these mixed by the Cholesky factor of its
        channel covariance (exact in distribution: the cell's H-V covariance does not depend on
        the lag). ``covariance``: independent coloured sequences (the two of :meth:`draw` when
        ``count`` is 2). ``monte_carlo``: the cell's drops, moved every PRT, seen with
        independent uniform backscatter phases per series (they share the drops' velocities
        and places, as :meth:`draw`'s H and V do).
        """
        if self.method == "monte_carlo":
            return self._drop_units(rows, gates, gen_h, gen_v, count, basis)
        series = self._series(rows, gates, basis.shape[0])
        return [series(gen_h if k == 0 else gen_v) for k in range(count)]

    def _drop_batches(
        self, rows: np.ndarray, gates: np.ndarray, gen_h: np.random.Generator, basis: np.ndarray
    ) -> Iterator[tuple[slice, np.ndarray, np.ndarray]]:
        """The cells' drops in batches: (cells, share, track) per batch.

        Each cell's ``drops`` drops get a velocity (the cell's mean and width), a backscatter
        phase and a sub-gate place, drawn from ``gen_h``; ``share`` (cell x component x drop)
        is what each drop puts on each range component, ``track`` (cell x drop x pulse) its
        phase at each pulse as it moves velocity x PRT every pulse.
        """
        d, pulses = self.drops, self.pulses
        r, n_fine = basis.shape
        k = -4 * np.pi / self.wavelength_m
        m = np.arange(pulses)
        # sqrt(n_fine) basis[:, s]: a drop at sub-gate place s gives each component unit power
        # on average over places (the basis rows have unit norm).
        weight = (basis * np.sqrt(n_fine)).astype(self.cdtype)
        # Cells in batches, so the drops x pulses phasors of a batch stay small in memory.
        batch = max(1, 2_000_000 // (d * max(pulses, r)))
        for a in range(0, rows.size, batch):
            b = min(rows.size, a + batch)
            rr, gg = rows[a:b], gates[a:b]
            mean = self.field["VRADH"][rr, gg][:, None]
            width = np.clip(self.field["WRADH"][rr, gg], 0, None)[:, None]
            velocity = mean + width * gen_h.standard_normal((b - a, d))
            position = gen_h.uniform(0.0, 2 * np.pi, (b - a, d))
            place = gen_h.integers(0, n_fine, (b - a, d))
            track = np.exp(
                1j * (position[..., None] + k * velocity[..., None] * (m * self.prt_s))
            ).astype(self.cdtype)
            yield slice(a, b), weight[:, place].transpose(1, 0, 2), track

    def _drop_units(
        self,
        rows: np.ndarray,
        gates: np.ndarray,
        gen_h: np.random.Generator,
        gen_v: np.random.Generator,
        count: int,
        basis: np.ndarray,
    ) -> list[np.ndarray]:
        n, r = rows.size, basis.shape[0]
        out = [np.empty((n, r, self.pulses), self.cdtype) for _ in range(count)]
        scale = self.cdtype(1 / np.sqrt(self.drops))
        for c, share, track in self._drop_batches(rows, gates, gen_h, basis):
            out[0][c] = scale * (share @ track)
            for z in out[1:]:
                phase = np.exp(1j * gen_v.uniform(0.0, 2 * np.pi, (c.stop - c.start, self.drops)))
                z[c] = scale * ((share * phase.astype(self.cdtype)[:, None, :]) @ track)
        return out

    def _complex(self, pairs: np.ndarray, n: int, r: int) -> np.ndarray:
        """Rows (real, imaginary) of coloured sequences as complex series: cell x comp x pulse."""
        out = np.empty((n * r, self.pulses), self.cdtype)
        out.real = pairs[:, 0]
        out.imag = pairs[:, 1]
        return out.reshape(n, r, self.pulses)

    def _drops(
        self,
        rows: np.ndarray,
        gates: np.ndarray,
        gen_h: np.random.Generator,
        gen_v: np.random.Generator,
        need_v: bool,
        basis: np.ndarray,
    ) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[tuple[np.ndarray, np.ndarray]]]:
        n, d, r = rows.size, self.drops, basis.shape[0]
        h = np.empty((n, r, self.pulses), self.cdtype)
        v = np.empty((n, r, self.pulses), self.cdtype) if need_v else None
        scale = 1 / np.sqrt(d)
        for c, share, track in self._drop_batches(rows, gates, gen_h, basis):
            rr, gg = rows[c], gates[c]
            sigma = np.sqrt(-2 * np.log(np.clip(self.rho[rr, gg], 1e-12, 1.0)) / 2)[:, None]
            phi_h = sigma * gen_h.standard_normal((rr.size, d))
            h[c] = scale * ((share * np.exp(1j * phi_h)[:, None, :]) @ track)
            if v is not None:
                phi_v = sigma * gen_v.standard_normal((rr.size, d))
                v[c] = (
                    scale
                    * ((share * np.exp(1j * phi_v)[:, None, :]) @ track)
                    * self.phase_dp[rr, gg][:, None, None]
                )
        ones = np.ones(n, self.cdtype)
        return [(h, ones)], ([(v, ones)] if v is not None else [])


class TruthCells:
    """What the weather channel needs of the truth, prepared once per run and shared by beams.

    Powers per cell (W per sr m, before pattern and range weighting), moments with fill values,
    each cell's velocity normalised for the range model's Doppler terms (``u``), the per-cell
    lag-1 correlation and H-V cross term for the expected correlations, and the per-cell
    time-series model of the chosen level. Fields are padded in range by the range model's
    reach with the edge gates' moments (the weather is taken to go on), at their own ranges,
    so the first and last gates see neighbours like every other gate; padding at or before
    zero range holds no echo.
    """

    def __init__(
        self,
        truth: xr.Dataset,
        ranges: RangeModel,
        k0: float,
        prt_s: float,
        wavelength_m: float,
        pulses: int,
        method: str,
        drops: int,
        dtype: type,
    ):
        pad = ranges.pad

        def padded(a: np.ndarray) -> np.ndarray:
            return np.pad(a, ((0, 0), (pad, pad)), mode="edge")

        rng_m = truth["range"].values
        step = float(truth.attrs["gate_width_m"])
        outside = step * np.arange(1, pad + 1)
        rng_p = np.concatenate([rng_m[0] - outside[::-1], rng_m, rng_m[-1] + outside])
        r2 = np.broadcast_to(rng_p**2, (truth.sizes["radial"], rng_p.size))
        dbz = padded(truth["DBZH"].values)
        # A gate at zero range (some legacy files start there) holds no echo volume.
        self.echo = np.isfinite(dbz) & (rng_p > 0)[None, :]
        self.s_h = np.where(
            self.echo,
            k0 * 10 ** (np.nan_to_num(dbz, nan=-999.0) / 10) / np.where(self.echo, r2, 1.0),
            0.0,
        )
        field = {k: padded(_filled(truth, k, np.isfinite(truth["DBZH"].values))) for k in FILL}
        self.s_v = self.s_h / 10 ** (np.clip(field["ZDR"], -8, 8) / 10)
        rho = np.clip(field["RHOHV"], 0.0, 1.0)
        width = np.clip(field["WRADH"], 0.0, None)
        a = np.pi * prt_s / wavelength_m
        # Per-cell expected lag-1 and H-V correlations, before pattern and range weighting;
        # computed on echo cells only (the others are zero).
        e = self.echo
        # r(1), r(2) of every cell, computed once: the cells are shared by every chunk and
        # thread of a run, so nothing here may be filled lazily.
        self._lags = np.stack(
            [
                np.exp(-8.0 * (a * width) ** 2) * _phasor(-4 * a * field["VRADH"]),
                np.exp(-32.0 * (a * width) ** 2) * _phasor(-8 * a * field["VRADH"]),
            ]
        )
        lag1 = np.exp(-8.0 * (a * width[e]) ** 2) * _phasor(-4 * a * field["VRADH"][e])
        self.r1_h = np.zeros(e.shape, np.complex128)
        self.r1_v = np.zeros(e.shape, np.complex128)
        self.cross = np.zeros(e.shape, np.complex128)
        self.r1_h[e] = self.s_h[e] * lag1
        self.r1_v[e] = self.s_v[e] * lag1
        self.cross[e] = (
            np.sqrt(self.s_h[e] * self.s_v[e]) * rho[e] * _phasor(np.deg2rad(field["PHIDP"][e]))
        )
        self.u = ranges.normalised_velocity(field["VRADH"])
        self.pulses = pulses
        self.dtype = dtype
        # The per-cell draws of every level but `expected`: all echo cells for covariance and
        # monte_carlo, the cells too narrow for the spectral draw for combined.
        self.per_cell = self.echo.copy() if method in ("covariance", "monte_carlo") else None
        self.model = None
        if method in ("covariance", "monte_carlo", "combined"):
            self.model = CellModel(
                "monte_carlo" if method == "monte_carlo" else "covariance",
                field,
                rho,
                self.echo,
                prt_s,
                wavelength_m,
                pulses,
                drops,
                dtype,
            )
        if method == "combined":
            self._spectra(field["VRADH"], width, prt_s, wavelength_m)

    def lags(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised lag-1 and lag-2 correlations r(1), r(2) of the cells of radials ``rows``."""
        return self._lags[0, rows], self._lags[1, rows]

    def sources(self, rows: np.ndarray, gates: Any = slice(None)) -> tuple[np.ndarray, ...]:
        """(S_h, S_v, Y, X) of cells: powers and E[s_hh s_vv*], E[s_hh* s_vv] (W per sr m)."""
        x = self.cross[rows, gates]
        return self.s_h[rows, gates], self.s_v[rows, gates], np.conj(x), x

    def _spectra(
        self, velocity: np.ndarray, width: np.ndarray, prt_s: float, wavelength_m: float
    ) -> None:
        # Cells share the spectrum of equal (velocity, width); velocity only matters modulo the
        # Nyquist interval. Rounding both to 0.01 m/s (far below any estimator's resolution)
        # keeps the number of distinct spectra small for any truth; Level-II data is on a
        # 0.5 m/s grid already.
        nyquist = wavelength_m / (4 * prt_s)
        v = np.round(np.mod(velocity + nyquist, 2 * nyquist) - nyquist, 2)
        w = np.round(width, 2)
        # One integer per (velocity, width) in 0.01 m/s steps: a 1-D unique is much faster.
        iv = np.rint(v[self.echo] * 100).astype(np.int64)
        iw = np.rint(w[self.echo] * 100).astype(np.int64)
        keys, codes = np.unique(iv * 10_000_000 + iw, return_inverse=True)
        pairs = np.stack([(keys // 10_000_000) / 100, (keys % 10_000_000) / 100], axis=1)
        lam, narrow = embedded_spectra(
            pairs[:, 0], pairs[:, 1], prt_s, wavelength_m, self.pulses, self.dtype
        )
        # A smaller embedding when every spectrum drawn this way decays fast enough: fewer
        # deviates and shorter FFTs for the same covariance to working precision.
        n = embedding_size(pairs[~narrow, 1], prt_s, wavelength_m, self.pulses, self.dtype)
        if n < 2 * self.pulses:
            lam, small_narrow = embedded_spectra(
                pairs[:, 0], pairs[:, 1], prt_s, wavelength_m, self.pulses, self.dtype, n
            )
            narrow |= small_narrow
        # One extra all-zero spectrum for cells without echo or drawn per cell.
        lam = np.concatenate([lam, np.zeros((1, lam.shape[1]), lam.dtype)])
        lam[np.flatnonzero(narrow)] = 0.0
        self.spectra = lam
        self.code = np.full(self.echo.shape, pairs.shape[0], np.int32)
        self.code[self.echo] = codes.ravel()
        narrow_cell = np.zeros(self.echo.shape, bool)
        narrow_cell[self.echo] = narrow[codes.ravel()]
        # Width 0 (common in Level-II data): a cell is a tone with a random complex amplitude,
        # and tones of one velocity add to one tone, so they are drawn per gate and velocity.
        self.tone = narrow_cell & (w == 0)
        self.per_cell = narrow_cell & ~self.tone
        self.wide = self.echo & ~narrow_cell
        self.tone_velocities, tone_codes = np.unique(v[self.tone], return_inverse=True)
        self.tone_code = np.zeros(self.echo.shape, np.int64)
        self.tone_code[self.tone] = tone_codes.ravel()
        m = np.arange(self.pulses)
        self.tones = np.exp(
            -4j * np.pi * prt_s / wavelength_m * self.tone_velocities[:, None] * m
        ).astype(np.complex64 if self.dtype == np.float32 else np.complex128)


class Coupling(NamedTuple):
    """The two-way polarimetric coupling of one beam's radials (:func:`coupling_weights`).

    ``weights[p, n, j]``: for channel pair p = (k, k') of :func:`pasim_blocks.polarimetry.pairs`
    and source n (S_h, S_v, Y, X), the integral over radial j of a_k[c] a_k'[c']* (sr): a cell
    with sources src has E[w_k w_k'*] = sum_n weights[p, n] src_n.
    """

    channels: int
    weights: np.ndarray

    def select(self, n: int) -> np.ndarray:
        """Weights of the pairs of the first ``n`` channels, in ``pairs(n)`` order."""
        index = {p: i for i, p in enumerate(pairs(self.channels))}
        return self.weights[[index[p] for p in pairs(n)]]


def coupling_weights(
    co: np.ndarray,
    cross: np.ndarray,
    d_az_deg: np.ndarray,
    d_el_deg: np.ndarray,
    elevation_deg: float,
    centre_deg: np.ndarray,
    width_deg: float,
    mode: str,
    transmit_phase_deg: float,
    channels: list[tuple[int, int]],
) -> np.ndarray:
    """Per channel pair and source, the coupling products integrated over each truth radial.

    The two-way couplings a_k[c] of the channels (:func:`pasim_blocks.polarimetry.channel_rows`)
    are multiplied pairwise, a_k[c] a_k'[c']*, integrated over elevation with cos(el) and over
    each radial's azimuth extent, as :func:`azimuth_profile` and :func:`cell_solid_angles`
    integrate the squared power pattern. Returns (pair, source, radial) complex (sr).
    """
    rows = channel_rows(co, cross, mode, transmit_phase_deg, channels)
    n_ch, n_el, n_az = rows.shape[0], rows.shape[2], rows.shape[3]
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))
    step = np.deg2rad(d_el_deg[1] - d_el_deg[0])
    # Every Hermitian product at once: per azimuth offset, the elevation-weighted Gram matrix
    # of the 2 n_ch coupling rows, summed in float64 (second-order cross-polar terms are
    # 1e-8 of the co-polar ones at -40 dB).
    x = np.empty((n_az, 2 * n_ch, n_el), np.complex128)
    x[...] = rows.reshape(2 * n_ch, n_el, n_az).transpose(2, 0, 1)
    weighted = x * (cos_el * step)
    np.conjugate(x, out=x)
    gram = (weighted @ x.transpose(0, 2, 1)).transpose(1, 2, 0)
    plist = pairs(n_ch)
    profile = np.empty((len(plist), 4, n_az), np.complex128)
    for i, (k, q) in enumerate(plist):
        for n, (c, c2) in enumerate(SOURCE_COMPONENTS):
            profile[i, n] = gram[2 * k + c, 2 * q + c2]
    flat = profile.reshape(-1, n_az)
    both = cell_solid_angles(
        np.concatenate([flat.real, flat.imag]), d_az_deg, centre_deg, width_deg
    )
    half = flat.shape[0]
    return (both[:half] + 1j * both[half:]).reshape(len(plist), 4, centre_deg.size)


class BeamDraw(NamedTuple):
    """What every drawing path needs for one beam: the truth cells, the radials near the beam
    and their two-way weights (``omega``: co-polar power patterns; ``coupling``: the complex
    co- and cross-polar fields, None without them), the range model, the beam's H and V random
    streams, the number of channels drawn (1: H only) and the transmission mode."""

    cells: TruthCells
    near: np.ndarray
    omega: np.ndarray
    ranges: RangeModel
    gen_h: np.random.Generator
    gen_v: np.random.Generator
    need_v: bool
    coupling: Coupling | None
    channels: int
    mode: str


class WeatherChannel(Block):
    """Echoes of the truth cells around each beam, at one of four fidelity levels.

    Every truth cell with echo inside the pattern grid is an independent Gaussian scatterer
    ensemble with a Gaussian Doppler spectrum (mean velocity, spectrum width), and H and V
    returns S_hh = V1, S_vv = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP) / sqrt(Z_dr). Each
    cell is weighted by the two-way H or V pattern integrated over its azimuth extent and all
    elevations (the truth is one sweep, taken as uniform in elevation). In range, a cell is a
    continuum of sub-gate scatterers seen through the radiated pulse (with its Doppler phase
    along the pulse) and the receive filter, at every gate the range response reaches, range
    sidelobes included (:mod:`pasim_blocks.fasttime`). Powers come from the radar equation,
    so a uniform field of Z dBZ gives back Z through the calibration output. The levels
    (``method``), fastest first:

    - ``expected``: no random draw. The echo's expected correlations (lag 0 and 1 of H and V,
      lag-0 H-V) through the beam and the range response's power (at each cell's velocity);
      the I/Q cube has no pulses and the pulse-pair processor estimates from
      ``echo_correlations``: the smoothing error alone.
    - ``combined``: each gate's series drawn at once from the pattern- and range-weighted sum
      of its cells' spectra over the whole range response, a 2 x 2 H-V matrix per frequency
      bin of a 2M circulant embedding (exact in distribution per gate for a sum of
      independent Gaussian processes; neighbouring gates are drawn independently); cells too
      narrow for the embedding are drawn per cell and added.
    - ``covariance``: per cell, paper eq. 13-18 (Cholesky colouring; one factor per distinct
      width), for each of the cell's independent range components, which the range response
      spreads over the gates: neighbouring gates correlate as the filter makes them.
    - ``monte_carlo``: per cell, ``drops_per_cell`` moving drops (paper eq. 5-12), each at a
      random place in the cell, spread over the gates likewise.

    Polarisation (``transmission``): SHV transmits H and V every pulse, the V port with the
    phase ``transmit_differential_phase_deg``; AHV alternates H (even pulses) and V (odd),
    and both ports receive every pulse. When the pattern carries complex co- and cross-polar
    fields (the arrays, ``antenna.measured``), each cell's received channels are v = M s with
    the two-way coupling M of those fields (:mod:`pasim_blocks.polarimetry`): their
    covariance, the integral over the cell's directions of M C_s M^H, is used at every level
    (the expected correlations; the combined level's spectral matrix, 2 x 2 in SHV, 4 x 4 in
    AHV for the stacked channels of both transmit states, each pulse keeping its state's
    pair; the per-cell levels' Cholesky factor of each cell's channel covariance applied to
    independent unit series of its spectrum). So cross-polarisation biases ZDR, rho_hv and
    phi_DP as in a real radar. Without those fields (pencil and ideal antennas, or
    ``cross_polar_coupling`` off) H and V are weighted by the squared co-polar power patterns
    and their cross term by sqrt(Omega_H Omega_V) (exact for proportional patterns).

    Gates inside the blind range (one pulse length) are zero. Each beam draws from its own
    random streams (H and V apart). A truth without ZDR, RHOHV and PHIDP (single
    polarisation), or a run that asks for none of them (nor, in AHV, for velocity or width),
    skips the V channel.
    """

    truth = Input(TRUTH, doc="truth sweep")
    beams = Input(BEAMS, doc="beam geometry")
    pattern = Input(PATTERN, doc="one-way H and V power patterns")
    range_response = Input(
        RANGE_RESPONSE, doc="radiated pulse, receive filter and their point-target response"
    )

    iq = Output(IQ, doc="echo voltages at the receive filter's output")
    signal_power = Output(SIGNAL_POWER, doc="expected echo power per gate")
    echo_correlations = Output(ECHO_CORRELATIONS, doc="expected echo correlations per gate")
    calibration = Output(CALIBRATION, doc="radar constant for power -> dBZ")

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    peak_power_w = Param(700e3, units="W", min=1e-3, max=1e8, doc="peak transmit power")
    loss_db = Param(0.0, units="dB", min=0.0, max=30.0, doc="two-way system losses")
    method = Param(
        "covariance",
        type="str",
        choices=METHODS,
        doc="fidelity level: expected, combined, covariance (eq. 13-18), monte_carlo (eq. 5-12)",
    )
    drops_per_cell = Param(
        256, type="int", min=1, max=100_000, doc="drops per truth cell (monte_carlo only)"
    )
    support_db = Param(
        -100.0,
        units="dB",
        min=-200.0,
        max=0.0,
        doc="ignore truth radials whose two-way weight is below this level (from the peak)",
    )
    range_support_db = Param(
        -80.0,
        units="dB",
        min=-150.0,
        max=-20.0,
        doc="range-response terms (gate offsets, sub-gate components, Doppler orders) below "
        "this level from the strongest are dropped",
    )
    precision = Param(
        "float32",
        type="str",
        choices=("float32", "float64"),
        doc="working precision of the random draws and sums",
    )
    transmission = Param(
        "shv",
        type="str",
        choices=MODES,
        doc="polarisation of transmission: shv (H and V every pulse), ahv (H and V alternate, "
        "H first)",
    )
    transmit_differential_phase_deg = Param(
        0.0,
        units="deg",
        min=-360.0,
        max=360.0,
        doc="phase of the V port's excitation against the H port's in SHV (the system's "
        "differential phase on transmit)",
    )
    cross_polar_coupling = Param(
        True,
        type="bool",
        doc="couple H and V through the antenna's complex co- and cross-polar fields when the "
        "pattern has them (false: co-polar power patterns only)",
    )

    # Fastest first, most faithful last; ``pasim tradeoff`` runs them all. -40 dB keeps the
    # main lobe and first sidelobes of a -32 dB antenna and drops the far ones.
    fidelity_ladder = (
        ("expected", {"method": "expected", "support_db": -100.0, "precision": "float64"}),
        ("combined-40dB", {"method": "combined", "support_db": -40.0, "precision": "float32"}),
        ("combined", {"method": "combined", "support_db": -100.0, "precision": "float32"}),
        ("combined-f64", {"method": "combined", "support_db": -100.0, "precision": "float64"}),
        ("covariance", {"method": "covariance", "support_db": -100.0, "precision": "float32"}),
        ("covariance-f64", {"method": "covariance", "support_db": -100.0, "precision": "float64"}),
        ("monte_carlo", {"method": "monte_carlo", "support_db": -100.0, "precision": "float32"}),
    )

    transient = ("_prepared",)

    def setup(self) -> None:
        self._prepared: tuple[Any, Any] | None = None

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        truth, beams = inputs["truth"], inputs["beams"]
        pattern, response = inputs["pattern"], inputs["range_response"]
        method = self.p["method"]
        dtype = np.float32 if self.p["precision"] == "float32" else np.float64
        lam = SPEED_OF_LIGHT / self.p["frequency_hz"]
        prt = float(beams["prt"].values[0])
        pulses = int(beams["pulses"].values)
        rng_m = truth["range"].values
        gate_m = float(truth.attrs["gate_width_m"])
        width_deg = float(truth.attrs["radial_width_deg"])
        az_truth = truth["azimuth"].values
        dual = all(k in truth for k in POLARIMETRIC_FIELDS)
        mode, beta = self.p["transmission"], float(self.p["transmit_differential_phase_deg"])
        # AHV estimates velocity from the H and V co-polar pulses together (processor).
        need_v = dual and (
            chunk.wants(*POLARIMETRIC_FIELDS) or (mode == "ahv" and chunk.wants("VRADH", "WRADH"))
        )
        coupled = bool(self.p["cross_polar_coupling"]) and all(
            k in pattern for k in ("co_polar", "cross_polar")
        )

        gain = 10 ** (pattern.attrs["gain_db"] / 10)
        k0 = (
            self.p["peak_power_w"]
            * gain**2
            * lam**2
            * np.pi**5
            * KW2
            * 1e-18
            / ((4 * np.pi) ** 3 * lam**4 * 10 ** (self.p["loss_db"] / 10))
        )
        n_b, n_g = beams.sizes["beam"], rng_m.size

        # What depends only on the truth and the range response is prepared once and reused
        # by every chunk (and, with threads, by every thread): a pure function of the inputs,
        # memoised.
        key = (id(truth), id(response), k0, prt, lam, pulses, method, dtype)
        key += (self.p["range_support_db"], self.p["drops_per_cell"])
        if self._prepared is None or self._prepared[0] != key:
            ranges = range_model(
                response,
                gate_m,
                lam,
                _largest_speed(truth),
                floor_db=self.p["range_support_db"],
            )
            cells = TruthCells(
                truth, ranges, k0, prt, lam, pulses, method, self.p["drops_per_cell"], dtype
            )
            self._prepared = (key, (ranges, cells))
        ranges, cells = self._prepared[1]

        d_az = pattern["azimuth_offset_deg"].values
        d_el = pattern["elevation_offset_deg"].values
        support = max(abs(d_az[0]), abs(d_az[-1])) + width_deg / 2
        cdtype = np.complex64 if dtype == np.float32 else np.complex128
        _check_coverage(az_truth, width_deg, beams["azimuth"].values, support - width_deg / 2)
        # Stored polarisation-major, handed on as a (beam, range, pulse, polarization) view:
        # each channel's series stay contiguous for the draws and for the blocks downstream.
        iq = np.zeros((n_b, 2, n_g, 0 if method == "expected" else pulses), cdtype)
        corr = np.zeros((n_b, n_g, len(CORRELATION_PRODUCTS)), np.complex128)
        drawn = 0 if method == "expected" else len(receive_channels(mode, need_v))
        for i, beam in enumerate(chunk.beams):
            az_b = float(beams["azimuth"].values[i])
            el_b = float(beams["elevation"].values[i])
            delta = circular_difference(az_truth, az_b, 360.0)
            near = np.flatnonzero(np.abs(delta) <= support)
            profile = azimuth_profile(pattern["power"].values[i], d_el, el_b)
            omega = cell_solid_angles(profile, d_az, delta[near], width_deg)
            keep = omega.max(axis=0) >= omega.max() * 10 ** (self.p["support_db"] / 10)
            near, omega = near[keep], omega[:, keep]
            coupling = None
            if coupled:
                # The expected correlations need both co-polar channels whatever is drawn.
                chans = receive_channels(mode, True)[: max(2, drawn)]
                coupling = Coupling(
                    len(chans),
                    coupling_weights(
                        pattern["co_polar"].values[i],
                        pattern["cross_polar"].values[i],
                        d_az,
                        d_el,
                        el_b,
                        delta[near],
                        width_deg,
                        mode,
                        beta,
                        chans,
                    ),
                )
            terms = ranges.power.shape[0]
            alternate = mode == "ahv"
            expected = (
                self._expected(cells, near, omega, terms, alternate)
                if coupling is None
                else self._expected_coupled(cells, near, coupling, terms, alternate)
            )
            corr[i] = range_correlate(expected, ranges.power.T, n_g, exact=True)
            if not alternate:
                corr[i, :, len(SHV_PRODUCTS) :] = np.nan
            if coupling is None and mode == "shv" and beta:
                # The V port's echo carries the transmit differential phase.
                corr[i] *= _beta_factors(beta)
            if method == "expected" or near.size == 0:
                continue
            gen_h, gen_v = chunk.rng(int(beam)), chunk.rng(int(beam), 1)
            draw = BeamDraw(cells, near, omega, ranges, gen_h, gen_v, need_v, coupling, drawn, mode)
            if coupling is None:
                if method == "combined":
                    self._combined(iq[i], draw)
                    self._tones(iq[i], draw)
                self._per_cell(iq[i], draw)
                if mode == "shv" and beta:
                    iq[i, 1] *= np.exp(1j * np.deg2rad(beta)).astype(cdtype)
                elif mode == "ahv":
                    # Without cross-polar fields a port receives nothing of the other
                    # polarisation's pulses.
                    iq[i, 0, :, 1::2] = 0
                    iq[i, 1, :, 0::2] = 0
            else:
                if method == "combined":
                    self._combined_coupled(iq[i], draw)
                    self._tones_coupled(iq[i], draw)
                self._per_cell_coupled(iq[i], draw)

        # The receiver is off while the pulse goes out: nothing is received inside the blind
        # range (the processor masks those gates and the scorer never scores them).
        blind_m = float(response.attrs["blind_range_m"])
        blind = rng_m < blind_m
        iq[:, :, blind] = 0
        corr[:, blind] = 0
        omega_cal = pattern["calibration_solid_angle_sr"].values  # beam x polarisation
        constant_db = 10 * np.log10(k0 * omega_cal * ranges.total_m)
        calibration = xr.Dataset(
            {
                "radar_constant_db": (
                    ("beam", "polarization"),
                    constant_db.astype(np.float64),
                    {"units": "dB"},
                )
            },
            coords={
                "range": ("range", rng_m, {"units": "meters"}),
                "polarization": list(POLARIZATIONS),
            },
            attrs={
                "wavelength_m": lam,
                "prt_s": prt,
                "dual_polarization": int(dual),
                "blind_range_m": blind_m,
                "calibration": str(pattern.attrs["calibration"]),
                "transmission": mode,
                "transmit_differential_phase_deg": beta,
                "cross_polar_coupling": int(coupled),
            },
        )
        power = corr[..., :2].real.astype(np.float32)
        return {
            "iq": np.moveaxis(iq.astype(np.complex64, copy=False), 1, -1),
            "signal_power": power,
            "echo_correlations": corr,
            "calibration": calibration,
        }

    @staticmethod
    def _expected(
        cells: TruthCells, near: np.ndarray, omega: np.ndarray, terms: int, alternate: bool
    ) -> Any:
        """Expected correlations per padded truth gate, before range weighting: gate x term x
        product (:data:`pasim_blocks.signals.CORRELATION_PRODUCTS`; the lag-2 and lag-1 H-V
        products only if ``alternate``, AHV, whose processor alone reads them).

        Term n carries each cell's contribution times u^n (its normalised velocity), so the
        range response's power r_d(u) = Σ_n power[n, d] u^n weighs every cell at its own
        velocity (range-Doppler coupling).
        """
        out = np.empty((cells.s_h.shape[1], terms, len(CORRELATION_PRODUCTS)), np.complex128)
        sq = np.sqrt(omega[0] * omega[1])
        u = cells.u[near]
        for n in range(terms):
            un = u**n if n else 1.0
            out[:, n, 0] = omega[0] @ (cells.s_h[near] * un)
            out[:, n, 1] = omega[1] @ (cells.s_v[near] * un)
            out[:, n, 2] = omega[0] @ (cells.r1_h[near] * un)
            out[:, n, 3] = omega[1] @ (cells.r1_v[near] * un)
            out[:, n, 4] = sq @ (cells.cross[near] * un)
        out[:, :, len(SHV_PRODUCTS) :] = 0.0
        if not alternate:
            return out
        lag1, lag2 = cells.lags(near)
        for n in range(terms):
            un = u**n if n else 1.0
            out[:, n, 5] = omega[0] @ (cells.s_h[near] * lag2 * un)
            out[:, n, 6] = omega[1] @ (cells.s_v[near] * lag2 * un)
            x1 = cells.cross[near] * lag1 * un
            out[:, n, 7] = sq @ x1
            out[:, n, 8] = sq @ (np.conj(cells.cross[near]) * lag1 * un)
        return out

    @staticmethod
    def _expected_coupled(
        cells: TruthCells, near: np.ndarray, coupling: Coupling, terms: int, alternate: bool
    ) -> Any:
        """:meth:`_expected` through the coupling of the co-polar channels h and v.

        Each cell's E[w_k w_k'*] is sum_n weights[k, k', n] src_n (:class:`Coupling`); a lag l
        multiplies it by the cell's r(l): R_l(h) = sum P_hh r(l), R1_HV = E[h_m* v_m+1] =
        sum conj(P_hv) r(1), R1_VH = E[v_m* h_m+1] = sum P_hv r(1).
        """
        w = coupling.select(2)  # pairs (h, h), (v, v), (h, v)
        # conj(P_hv) = sum_n conj(w_hv[n]) conj(src_n): conjugation swaps sources Y and X.
        w_hv_conj = np.conj(w[2][list(CONJUGATE_SOURCES)])
        n_j, n_g = near.size, cells.s_h.shape[1]
        # Only the gates some near radial has echo at.
        gates = np.flatnonzero(cells.echo[near].any(axis=0))
        src = np.empty((4, n_j, gates.size), np.complex128)  # source x radial x gate
        for k, a in enumerate(cells.sources(near[:, None], gates[None, :])):
            src[k] = a
        lag1, lag2 = (lag[:, gates] for lag in cells.lags(near))
        u = cells.u[near][:, gates]
        # Products by lag: lag 0 -> R0_H, R0_V, R0_HV; lag 1 -> R1_H, R1_V, R1_HV, R1_VH; lag
        # 2 -> R2_H, R2_V. One matrix product each over (source, radial).
        plan = (
            (None, np.stack([w[0], w[1], w_hv_conj]), (0, 1, 4)),
            (lag1, np.stack([w[0], w[1], w_hv_conj, w[2]]), (2, 3, 7, 8)),
            (lag2, np.stack([w[0], w[1]]), (5, 6)),
        )
        if not alternate:
            plan = (plan[0], (lag1, np.stack([w[0], w[1]]), (2, 3)))
        out = np.zeros((n_g, terms, len(CORRELATION_PRODUCTS)), np.complex128)
        for n in range(terms):
            s0 = src * u**n if n else src
            for lag, weights, index in plan:
                s = s0 if lag is None else s0 * lag
                out[np.ix_(gates, [n], list(index))] = (
                    weights.reshape(len(index), 4 * n_j) @ s.reshape(4 * n_j, gates.size)
                ).T[:, None, :]
        out[:, :, :2] = out[:, :, :2].real
        return out

    @staticmethod
    def _per_cell(out: np.ndarray, beam: BeamDraw) -> None:
        """Add the per-cell draws (covariance, monte_carlo, or combined's narrow cells).

        Each cell draws its independent range components, which the range model spreads over
        the gates it reaches (:class:`pasim_blocks.fasttime.GateSum`).
        """
        cells, near, omega, ranges, gen_h, gen_v, need_v = beam[:7]
        if cells.per_cell is None or cells.model is None:
            return
        # Cells ordered by gate, then radial, so that each gate's sum is one segment.
        gg, jj = np.nonzero(cells.per_cell[near].T)
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

    @staticmethod
    def _gate_spectra(
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
        weights = np.stack(stacked).transpose(2, 0, 1).astype(dtype)  # g x TP x J
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

    @staticmethod
    def _combined(out: np.ndarray, beam: BeamDraw) -> None:
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
        summed = WeatherChannel._gate_spectra(beam, [p[:, gsel] for p in products], gsel, n_g)
        if summed is None:
            return
        gates, s = summed
        # sqrt(N) ifft(.)[:M] has covariance c[m - n] (see embedded_spectra); sqrt(N) and the
        # power scale go on the factors before the FFT.
        s *= dtype(scale * n)
        s_hh = np.maximum(s[:, 0], 0)
        l11 = np.sqrt(s_hh)
        z1 = _complex_normal(gen_h, s_hh.shape, dtype)
        # This level runs first on a zeroed beam: assign, the other paths add.
        out[0, gates] = scipy.fft.ifft(l11 * z1, axis=-1, overwrite_x=True)[:, :pulses]
        if not need_v:
            return
        inv = np.divide(1, l11, out=np.zeros_like(l11), where=l11 > 0)
        l21 = (s[:, 2] * inv) + 1j * (s[:, 3] * inv)
        l22 = np.sqrt(np.maximum(np.maximum(s[:, 1], 0) - (l21.real**2 + l21.imag**2), 0))
        z2 = _complex_normal(gen_v, s_hh.shape, dtype)
        out[1, gates] = scipy.fft.ifft(l21 * z1 + l22 * z2, axis=-1, overwrite_x=True)[:, :pulses]

    @staticmethod
    def _combined_coupled(out: np.ndarray, beam: BeamDraw) -> None:
        """:meth:`_combined` with the coupled channels: an n x n spectral matrix per bin.

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
        cov = cell_covariance(beam.coupling.select(n_ch)[..., None], src)  # pair x J x g
        scale = float(cov[0].real.max()) or 1.0
        plist = pairs(n_ch)
        products = []
        for p, (k, q) in enumerate(plist):
            products += [cov[p].real / scale] + ([cov[p].imag / scale] if k != q else [])
        summed = WeatherChannel._gate_spectra(beam, products, gsel, n_g)
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
        z = [_complex_normal(gen_h if k == 0 else gen_v, s[:, 0].shape, dtype) for k in range(n_ch)]
        series = [
            scipy.fft.ifft(
                sum(factor[k, i] * z[i] for i in range(k + 1)), axis=-1, overwrite_x=True
            )[:, :pulses]
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

    @staticmethod
    def _tones(out: np.ndarray, beam: BeamDraw) -> None:
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
        z1 = _complex_normal(gen_h, (uniq.size,), np.float64)
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
            a_v = l21 * z1 + l22 * _complex_normal(gen_v, (uniq.size,), np.float64)
            out[1, gates] += np.add.reduceat(a_v[:, None] * cells.tones[c_u], starts, axis=0)

    @staticmethod
    def _tones_coupled(out: np.ndarray, beam: BeamDraw) -> None:
        """:meth:`_tones` with the coupled channels (n x n factor per gate and velocity)."""
        cells, near, ranges = beam.cells, beam.near, beam.ranges
        n_ch = beam.channels
        jj, gg = np.nonzero(cells.tone[near])
        if not jj.size:
            return
        n_g, pad = out.shape[1], ranges.pad
        rows = near[jj]
        code = cells.tone_code[rows, gg]
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
        z = [_complex_normal(beam.gen_h, (uniq.size,), np.float64)]
        z += [_complex_normal(beam.gen_v, (uniq.size,), np.float64) for _ in range(1, n_ch)]
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

    @staticmethod
    def _per_cell_coupled(out: np.ndarray, beam: BeamDraw) -> None:
        """:meth:`_per_cell` with the coupled channels.

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
        if not gg.size:
            return
        n_ch = beam.channels
        n_g, pulses = out.shape[1], out.shape[2]
        rows = near[jj]
        u = cells.u[rows, gg]
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
                            mix[..., parity::2] += (
                                factor[k, i, c][:, None, None] * z[i][..., parity::2]
                            )
                    terms = [(mix, np.ones(mix.shape[0], out.dtype))]
                acc.add([t for t in terms if t[1].any()], u[c], gg[c])
        for k, acc in enumerate(sums):
            lo, volts = acc.voltages()
            out[k, lo : lo + volts.shape[0]] += volts


def _largest_speed(truth: xr.Dataset) -> float:
    """The largest |radial velocity| of a cell with echo (0 without velocities)."""
    if "VRADH" not in truth:
        return 0.0
    v = np.abs(truth["VRADH"].values[np.isfinite(truth["DBZH"].values)])
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else 0.0


def _check_coverage(
    az_truth: np.ndarray, width_deg: float, az_beams: np.ndarray, support_deg: float
) -> None:
    """Refuse beams whose pattern reaches beyond a truth read for a sector only.

    A truth read for a sector (``truth.azimuth_start_deg``) ends somewhere; a beam whose
    pattern grid reaches past that end would silently miss the echo there.
    """
    az = np.sort(np.mod(az_truth, 360.0))
    if az.size < 2:
        return
    gaps = np.diff(np.concatenate([az, [az[0] + 360.0]]))
    k = int(np.argmax(gaps))
    if gaps[k] <= 2.5 * width_deg:
        return  # the whole circle
    start = az[(k + 1) % az.size] - width_deg / 2
    extent = 360.0 - gaps[k] + width_deg
    off = np.mod(az_beams - support_deg - start, 360.0)
    bad = off + 2 * support_deg > extent + 1e-6
    if bad.any():
        b = float(az_beams[np.flatnonzero(bad)[0]])
        raise ValueError(
            f"the truth covers azimuth {start % 360:.1f} to {(start + extent) % 360:.1f} deg, but "
            f"the beam at {b:.1f} deg has a pattern support of +-{support_deg:g} deg; widen the "
            "truth's margin_deg (or read the whole sweep)"
        )


def _beta_factors(beta_deg: float) -> np.ndarray:
    """Factors on the correlation products when the V port's echo is multiplied by e^(j beta)."""
    t = np.exp(1j * np.deg2rad(beta_deg))
    factors = {"R0_HV": t, "R1_HV": t, "R1_VH": np.conj(t)}
    return np.array([factors.get(k, 1.0) for k in CORRELATION_PRODUCTS])


def _phasor(phase: np.ndarray) -> np.ndarray:
    """exp(j phase), from cos and sin (a complex exp of a real argument costs twice as much)."""
    out = np.empty(phase.shape, np.complex128)
    out.real = np.cos(phase)
    out.imag = np.sin(phase)
    return out


def _complex_normal(gen: np.random.Generator, shape: tuple[int, ...], dtype: type) -> np.ndarray:
    """Circular complex Gaussian deviates with E|z|^2 = 1."""
    # Real and imaginary parts drawn side by side and viewed as complex: no copies.
    w = gen.standard_normal((*shape[:-1], 2 * shape[-1]), dtype=dtype)
    w *= dtype(np.sqrt(0.5))
    return w.view(np.complex64 if dtype == np.float32 else np.complex128)


def _filled(truth: xr.Dataset, name: str, echo: np.ndarray) -> np.ndarray:
    if name not in truth:
        return np.full(echo.shape, FILL[name])
    values = truth[name].values.astype(np.float64)
    return np.where(np.isfinite(values), values, FILL[name])
