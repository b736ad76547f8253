"""The truth cells as the weather channel sees them: powers, spectra and polarimetry per cell,
prepared once per truth and range model, and the per-cell series models (Cholesky colouring for
``covariance``, moving drops for ``monte_carlo``).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import numpy as np
import xarray as xr

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
from .dsd import DropSizes, fit_drop_sizes
from .fasttime import RangeModel
from .spectra import (
    FactorCache,
    embedded_spectra,
    embedding_size,
    phasor,
)

# Moments used for a cell that has reflectivity but lacks another field (e.g. beyond the
# Doppler cut's range): a still, narrow-spectrum, well-correlated echo.
FILL = {"VRADH": 0.0, "WRADH": 1.0, "ZDR": 0.0, "RHOHV": 0.99, "PHIDP": 0.0}


class CellModel:
    """Unit-power H and V slow-time series of truth cells, by one of the paper's two methods.

    ``draw(rows, gates, gen_h, gen_v, need_v, basis)`` returns H and V as lists of terms
    (series, factor per cell), the channel being Σ factor x series; each series is cell x
    component x pulse: the cell's ``r`` independent range components (``basis``, r x n_fine:
    how each is made of the cell's sub-gate scatterers, see
    :mod:`pasim_blocks.weather.fasttime`), with E|h|^2 = 1 and E|v|^2 = 1 (powers, pattern and
    range weights are applied by the caller).
    H is drawn from ``gen_h`` only, so it is the same whether or not V is asked for:

    - ``covariance`` (eq. 13-18): V1, V2 coloured with the Cholesky factor of the Gaussian
      autocorrelation, h = V1, v = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP), per component
      (a unitary rotation of independent sub-gate scatterers leaves them independent).
    - ``monte_carlo`` (eq. 5-12): ``drops`` equal drops per cell at random positions (uniform
      phase, and a uniform place among the cell's sub-gate scatterers, which sets what each
      range component receives from it), each with its own radial velocity drawn from N(mean
      velocity, width^2) and moved every PRT; random backscatter phases with sigma_h = sigma_v
      = sigma / sqrt(2), sigma = sqrt(-2 ln rho_hv), give rho_hv = exp(-sigma^2 / 2).
      With ``sizes`` (drop size distributions, :mod:`pasim_blocks.weather.dsd`) the drops
      have their own diameters, drawn from the reflectivity-weighted gamma distribution
      fitted to the cell (its grid index in ``codes``), and each drop's V amplitude is its
      own V/H amplitude ratio (no random backscatter phases): ZDR, rho_hv and the
      backscatter phase come from the drops; ``phase_dp`` is then the propagation part.
    """

    def __init__(
        self,
        method: str,
        field: dict[str, np.ndarray],
        rho: np.ndarray,
        phase_dp: np.ndarray,
        factors: FactorCache | None,
        prt_s: float,
        wavelength_m: float,
        pulses: int,
        drops: int,
        dtype: type = np.float32,
        sizes: DropSizes | None = None,
        codes: np.ndarray | None = None,
    ):
        self.method = method
        self.sizes, self.codes = sizes, codes
        self.field = field
        self.rho = rho
        self.prt_s, self.wavelength_m, self.pulses, self.drops = prt_s, wavelength_m, pulses, drops
        self.dtype = dtype
        self.cdtype = np.complex64 if dtype == np.float32 else np.complex128
        # exp(j phi_DP) per cell (the propagation part only, with drop sizes).
        self.phase_dp = phase_dp
        if factors is not None:
            self.factors = factors

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
            if self.sizes is not None and self.codes is not None:
                # Drops of their own sizes: unit H amplitude (reflectivity-weighted draw),
                # V amplitude their V/H ratio, from gen_h so H does not depend on need_v.
                _, q = self.sizes.draw(self.codes[rr, gg], gen_h, d)
                h[c] = scale * (share @ track)
                if v is not None:
                    v[c] = (
                        scale
                        * ((share * q.astype(self.cdtype)[:, None, :]) @ track)
                        * self.phase_dp[rr, gg][:, None, None]
                    )
                continue
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

    Every quantity of a cell depends on that cell alone, so the cells are prepared a block of
    radials at a time, when a beam first reaches them (:meth:`prepare`, which the channel
    calls with each beam's rows before reading them): a worker that runs a few chunks of a
    long scan prepares the radials near them, not the whole truth (on a cluster of many
    workers that was most of a worker's first-use time). The same values to the bit either
    way. The whole truth is prepared at once where a cell's values depend on other cells: the
    ``combined`` level's table of distinct spectra, and drop sizes (their system offset is a
    mean over the sweep).
    """

    #: Radials prepared at a time: a chunk of 8 beams reaches a few dozen.
    BLOCK_ROWS = 16

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
        sizes: DropSizes | None = None,
    ):
        self._truth, self._ranges, self._k0 = truth, ranges, k0
        self._a = np.pi * prt_s / wavelength_m
        self.pulses = pulses
        self.dtype = dtype
        rng_m = truth["range"].values
        step = float(truth.attrs["gate_width_m"])
        outside = step * np.arange(1, ranges.pad + 1)
        rng_p = np.concatenate([rng_m[0] - outside[::-1], rng_m, rng_m[-1] + outside])
        self._r2 = rng_p**2
        dbz = self._padded(truth["DBZH"].values)
        self._dbz = dbz
        # A gate at zero range (some legacy files start there) holds no echo volume.
        self.echo = np.isfinite(dbz) & (rng_p > 0)[None, :]
        shape = dbz.shape
        # The per-cell draws of every level but `expected`: all echo cells for covariance and
        # monte_carlo, the cells too narrow for the spectral draw for combined.
        self.per_cell = self.echo.copy() if method in ("covariance", "monte_carlo") else None
        self.factors = None
        if method in ("covariance", "combined"):
            # The distinct widths over the whole truth: each cell's code is its width's index.
            width = np.clip(self._field("WRADH", slice(None)), 0.0, None)
            self.factors = FactorCache(
                np.unique(width[self.echo]), shape, prt_s, wavelength_m, pulses, dtype
            )
        self._done = np.zeros(-(-shape[0] // self.BLOCK_ROWS), bool)
        self._lock = threading.Lock()
        # Zero until their radials are prepared (all at once below where a cell depends on
        # others); pages never touched cost nothing.
        self.s_h: np.ndarray = np.zeros(shape)
        self.s_v: np.ndarray = np.zeros(shape)
        self.u: np.ndarray = np.zeros(shape)
        self.rho: np.ndarray = np.zeros(shape)
        self.r1_h: np.ndarray = np.zeros(shape, np.complex128)
        self.r1_v: np.ndarray = np.zeros(shape, np.complex128)
        self.cross: np.ndarray = np.zeros(shape, np.complex128)
        self.phase_dp: np.ndarray = np.zeros(shape, np.complex128)
        self._lags: np.ndarray = np.zeros((2, *shape), np.complex128)
        self.field: dict[str, np.ndarray] = {k: np.zeros(shape) for k in FILL}
        codes = None
        if sizes is not None or method == "combined":
            field = {k: self._field(k, slice(None)) for k in FILL}
            propagation = None
            if sizes is not None:
                codes, propagation = fit_drop_sizes(sizes, field, dbz, self.echo, step)
            self._put(slice(None), self._cells(slice(None), field, propagation))
            self._done[:] = True
        self.model = None
        if method in ("covariance", "monte_carlo", "combined"):
            self.model = CellModel(
                "monte_carlo" if method == "monte_carlo" else "covariance",
                self.field,
                self.rho,
                self.phase_dp,
                self.factors,
                prt_s,
                wavelength_m,
                pulses,
                drops,
                dtype,
                sizes,
                codes,
            )
        if method == "combined":
            width = np.clip(self.field["WRADH"], 0.0, None)
            self._spectra(self.field["VRADH"], width, prt_s, wavelength_m)

    def prepare(self, rows: np.ndarray) -> None:
        """Prepare the cells of radials ``rows`` (and their blocks) if not done yet; safe
        from several threads (the threaded scheduler shares one channel's cells)."""
        blocks = np.unique(np.asarray(rows) // self.BLOCK_ROWS)
        todo = blocks[~self._done[blocks]]
        if not todo.size:
            return
        with self._lock:
            for b in todo:
                if self._done[b]:
                    continue
                sl = slice(int(b) * self.BLOCK_ROWS, (int(b) + 1) * self.BLOCK_ROWS)
                field = {k: self._field(k, sl) for k in FILL}
                self._put(sl, self._cells(sl, field, None))
                self._done[b] = True

    def _padded(self, a: np.ndarray) -> np.ndarray:
        pad = self._ranges.pad
        return np.pad(a, ((0, 0), (pad, pad)), mode="edge")

    def _field(self, name: str, rows: slice) -> np.ndarray:
        """Moment ``name`` of radials ``rows``, filled where missing and padded in range."""
        truth = self._truth
        if name not in truth:
            return self._padded(np.full(truth["DBZH"].values[rows].shape, FILL[name]))
        values = truth[name].values[rows].astype(np.float64)
        return self._padded(np.where(np.isfinite(values), values, FILL[name]))

    def _cells(
        self, rows: slice, field: dict[str, np.ndarray], propagation: np.ndarray | None
    ) -> dict[str, Any]:
        """Every per-cell quantity of radials ``rows`` from their (padded) moments."""
        e = self.echo[rows]
        dbz = self._dbz[rows]
        r2 = np.broadcast_to(self._r2, dbz.shape)
        k0, a = self._k0, self._a
        s_h = np.where(
            e, k0 * 10 ** (np.nan_to_num(dbz, nan=-999.0) / 10) / np.where(e, r2, 1.0), 0.0
        )
        s_v = s_h / 10 ** (np.clip(field["ZDR"], -8, 8) / 10)
        rho = np.clip(field["RHOHV"], 0.0, 1.0)
        width = np.clip(field["WRADH"], 0.0, None)
        # r(1), r(2) of every cell; the expected correlations' lag-1 and H-V terms, before
        # pattern and range weighting, on echo cells only (the others are zero).
        lags = np.stack(
            [
                np.exp(-8.0 * (a * width) ** 2) * phasor(-4 * a * field["VRADH"]),
                np.exp(-32.0 * (a * width) ** 2) * phasor(-8 * a * field["VRADH"]),
            ]
        )
        lag1 = np.exp(-8.0 * (a * width[e]) ** 2) * phasor(-4 * a * field["VRADH"][e])
        r1_h = np.zeros(e.shape, np.complex128)
        r1_v = np.zeros(e.shape, np.complex128)
        cross = np.zeros(e.shape, np.complex128)
        r1_h[e] = s_h[e] * lag1
        r1_v[e] = s_v[e] * lag1
        cross[e] = np.sqrt(s_h[e] * s_v[e]) * rho[e] * phasor(np.deg2rad(field["PHIDP"][e]))
        out: dict[str, Any] = {
            "s_h": s_h,
            "s_v": s_v,
            "rho": rho,
            "lags": lags,
            "r1_h": r1_h,
            "r1_v": r1_v,
            "cross": cross,
            "u": self._ranges.normalised_velocity(field["VRADH"]),
            "phase_dp": np.exp(
                1j * np.deg2rad(field["PHIDP"] if propagation is None else propagation)
            ),
            "field": field,
        }
        if self.factors is not None:
            codes = np.full(e.shape, -1, np.int64)
            codes[e] = np.searchsorted(self.factors.widths, width[e])
            out["codes"] = codes
        return out

    def _put(self, rows: slice, cells: dict[str, Any]) -> None:
        """Radials ``rows`` of this object's arrays set to ``cells`` (:meth:`_cells`)."""
        for name, value in cells.items():
            if name == "field":
                for k, v in value.items():
                    self.field[k][rows] = v
            elif name == "lags":
                self._lags[:, rows] = value
            elif name == "codes":
                self.factors.code[rows] = value  # type: ignore[union-attr]
            else:
                getattr(self, name)[rows] = value

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


def flat_volume(truth: xr.Dataset) -> xr.Dataset:
    """A volume truth's sweeps as one (radial, gate) truth, sweep-major: row s x radials + j is
    sweep s, radial j (the rows the weather channel weights per beam and elevation)."""
    names = [
        str(n)
        for n in truth.data_vars
        if str(n).startswith("volume_") and not str(n).endswith("_wind")
    ]
    n_s, n_r, n_g = truth.sizes["sweep"], truth.sizes["radial"], truth.sizes["gate"]
    return xr.Dataset(
        {
            n.removeprefix("volume_"): (("radial", "gate"), truth[n].values.reshape(n_s * n_r, n_g))
            for n in names
        },
        coords={"range": ("gate", truth["range"].values)},
        attrs=dict(truth.attrs),
    )
