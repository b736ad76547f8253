"""The weather channel: truth cells -> dual-polarisation echo time series at every gate."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from .angles import circular_difference
from .signals import (
    BEAMS,
    CALIBRATION,
    IQ,
    KW2,
    PATTERN,
    POLARIZATIONS,
    RANGE_RESPONSE,
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


def range_weights(response: xr.Dataset, gate_width_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Integrate the range weighting |y|^2 over whole gates at offsets k = -K..K.

    Returns the gate offsets k and the integrals (metres).
    """
    x = response["offset_m"].values
    w = response["power_weight"].values
    dx = np.diff(x).mean() if x.size > 1 else gate_width_m
    # Cumulative integral with each sample standing for the interval around it.
    edges = np.concatenate([x - dx / 2, [x[-1] + dx / 2]])
    cum = np.concatenate([[0.0], np.cumsum(w * dx)])
    k_max = int(np.ceil(max(abs(x[0]), abs(x[-1])) / gate_width_m + 0.5))
    k = np.arange(-k_max, k_max + 1)
    lo = np.interp((k - 0.5) * gate_width_m, edges, cum)
    hi = np.interp((k + 0.5) * gate_width_m, edges, cum)
    r = hi - lo
    keep = r > r.max() * 1e-12
    return k[keep], r[keep]


def azimuth_profile(power: np.ndarray, d_el_deg: np.ndarray, elevation_deg: float) -> np.ndarray:
    """Two-way pattern integrated over elevation (rad), per polarisation and azimuth offset."""
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el_deg))[None, :, None]
    step = np.deg2rad(d_el_deg[1] - d_el_deg[0])
    p = power.astype(np.float64)
    return np.sum(p * p * cos_el, axis=1) * step


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
    width_ms: np.ndarray, prt_s: float, wavelength_m: float, pulses: int
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
    return factors.astype(np.float32)


class FactorCache:
    """Cholesky factors of eq. 13 per distinct spectrum width, shared by cells and beams.

    Level-II widths come in 0.5 m/s steps, so a sweep holds a few dozen distinct values: one
    factorisation per value is exact and replaces one per cell. Factors are computed the first
    time a width is needed.
    """

    def __init__(
        self, width_ms: np.ndarray, echo: np.ndarray, prt_s: float, wavelength_m: float, pulses: int
    ):
        self.widths, codes = np.unique(width_ms[echo], return_inverse=True)
        self.code = np.full(echo.shape, -1, np.int64)
        self.code[echo] = codes.ravel()
        self.args = (prt_s, wavelength_m, pulses)
        self.factors: dict[int, np.ndarray] = {}

    def colour(self, codes: np.ndarray, gen: np.random.Generator) -> np.ndarray:
        """Draw coloured sequences for cells with width codes ``codes``: (cell, 4, pulse).

        Cells are drawn grouped by width so each group is one matrix product on contiguous
        memory; the four rows per cell are the real and imaginary parts of V1 and V2.
        """
        pulses = self.args[2]
        order = np.argsort(codes, kind="stable")
        sorted_codes = codes[order]
        bounds = np.flatnonzero(np.diff(sorted_codes)) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [codes.size]])
        missing = [int(c) for c in sorted_codes[starts] if int(c) not in self.factors]
        if missing:
            new = gaussian_acf_factors(self.widths[missing], *self.args)
            self.factors.update(zip(missing, new, strict=True))
        white = gen.standard_normal((codes.size, 4, pulses), dtype=np.float32)
        out = np.empty_like(white)
        for a, b in zip(starts, stops, strict=True):
            factor = self.factors[int(sorted_codes[a])]
            out[a:b] = (white[a:b].reshape(-1, pulses) @ factor.T).reshape(b - a, 4, pulses)
        # Back to the callers' cell order.
        result = np.empty_like(out)
        result[order] = out
        return result


class CellModel:
    """Unit-power H and V slow-time series of truth cells, by one of the paper's two methods.

    ``draw(rows, gates, gen)`` returns (h, v), each cell x pulse complex64, with E|h|^2 = 1
    and E|v|^2 = 1 (powers and pattern weights are applied by the caller):

    - ``covariance`` (eq. 13-18): V1, V2 coloured with the Cholesky factor of the Gaussian
      autocorrelation, h = V1, v = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP).
    - ``monte_carlo`` (eq. 5-12): ``drops`` equal drops per cell at random positions (uniform
      phase), each with its own radial velocity drawn from N(mean velocity, width^2) and
      moved every PRT; random backscatter phases with sigma_h = sigma_v = sigma / sqrt(2),
      sigma = sqrt(-2 ln rho_hv), give rho_hv = exp(-sigma^2 / 2).
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
    ):
        self.method = method
        self.field = field
        self.rho = rho
        self.prt_s, self.wavelength_m, self.pulses, self.drops = prt_s, wavelength_m, pulses, drops
        self.phase_dp = np.exp(1j * np.deg2rad(field["PHIDP"]))
        if method == "covariance":
            self.factors = FactorCache(
                np.clip(field["WRADH"], 0, None), echo, prt_s, wavelength_m, pulses
            )

    def draw(
        self, rows: np.ndarray, gates: np.ndarray, gen: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        if self.method == "monte_carlo":
            return self._drops(rows, gates, gen)
        m = np.arange(self.pulses)[None, :]
        y = self.factors.colour(self.factors.code[rows, gates], gen)
        doppler = np.exp(
            (-4j * np.pi * self.prt_s / self.wavelength_m)
            * (self.field["VRADH"][rows, gates][:, None] * m)
        ).astype(np.complex64)
        # sqrt(1/2): the white sequences have unit variance per real component.
        x1 = (y[:, 0] + 1j * y[:, 1]) * doppler * np.float32(np.sqrt(0.5))
        x2 = (y[:, 2] + 1j * y[:, 3]) * doppler * np.float32(np.sqrt(0.5))
        r = self.rho[rows, gates][:, None].astype(np.float32)
        v = (r * x1 + np.sqrt(1 - r**2) * x2) * self.phase_dp[rows, gates][:, None]
        return x1, v.astype(np.complex64)

    def _drops(
        self, rows: np.ndarray, gates: np.ndarray, gen: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        n, d, pulses = rows.size, self.drops, self.pulses
        h = np.empty((n, pulses), np.complex64)
        v = np.empty((n, pulses), np.complex64)
        k = -4 * np.pi / self.wavelength_m
        m = np.arange(pulses)
        # Cells in batches, so the drops x pulses phasors of a batch stay small in memory.
        batch = max(1, 2_000_000 // (d * pulses))
        for a in range(0, n, batch):
            b = min(n, a + batch)
            rr, gg = rows[a:b], gates[a:b]
            mean = self.field["VRADH"][rr, gg][:, None]
            width = np.clip(self.field["WRADH"][rr, gg], 0, None)[:, None]
            velocity = mean + width * gen.standard_normal((b - a, d))
            position = gen.uniform(0.0, 2 * np.pi, (b - a, d))
            sigma = np.sqrt(-2 * np.log(np.clip(self.rho[rr, gg], 1e-12, 1.0)) / 2)[:, None]
            phi_h = sigma * gen.standard_normal((b - a, d))
            phi_v = sigma * gen.standard_normal((b - a, d))
            # Phase of each drop at each pulse: it moves velocity * PRT every pulse.
            track = np.exp(1j * (position[..., None] + k * velocity[..., None] * (m * self.prt_s)))
            scale = 1 / np.sqrt(d)
            h[a:b] = scale * np.einsum("cd,cdm->cm", np.exp(1j * phi_h), track)
            v[a:b] = (
                scale
                * np.einsum("cd,cdm->cm", np.exp(1j * phi_v), track)
                * self.phase_dp[rr, gg][:, None]
            )
        return h, v


class WeatherChannel(Block):
    """Echoes of the truth cells around each beam: paper's covariance method (eq. 13-18).

    Every truth cell with echo inside the pattern grid is an independent Gaussian scatterer
    ensemble. Its slow-time series is drawn with the covariance of a Gaussian Doppler spectrum
    (mean velocity, spectrum width; Cholesky colouring of two white sequences V1, V2), and its
    H and V returns are S_hh = V1 and S_vv = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP) /
    sqrt(Z_dr). Each cell is weighted by the two-way H or V pattern integrated over its
    azimuth extent and all elevations (the truth is one sweep, taken as uniform in elevation),
    and each gate sums the cells around it with the waveform's range weighting. Powers come
    from the radar equation, so a uniform field of Z dBZ gives back Z through the calibration
    output. Each beam draws from its own random stream.

    Inputs
    ------
    truth : truth_sweep
    beams : beams
    pattern : pattern
    range_response : range_response

    Outputs
    -------
    iq : iq
        Noise-free echo voltages, beam x range x pulse x polarisation, sqrt(W).
    signal_power : signal_power
        Expected echo power per gate (W), noise-free.
    calibration : calibration
        Radar constant per beam and polarisation, and the gate ranges. It is the boresight
        (broadside) constant for every beam: scan loss and the H/V mismatch of a steered array
        are deliberately left uncalibrated, as in the paper (its planar array shows a ZDR bias
        growing off broadside).
    """

    truth = Input(TRUTH, doc="truth sweep")
    beams = Input(BEAMS, doc="beam geometry")
    pattern = Input(PATTERN, doc="one-way H and V power patterns")
    range_response = Input(RANGE_RESPONSE, doc="range weighting after the matched filter")

    iq = Output(IQ, doc="echo voltages at the matched-filter output")
    signal_power = Output(SIGNAL_POWER, doc="expected echo power per gate")
    calibration = Output(CALIBRATION, doc="radar constant for power -> dBZ")

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    peak_power_w = Param(700e3, units="W", min=1e-3, max=1e8, doc="peak transmit power")
    loss_db = Param(0.0, units="dB", min=0.0, max=30.0, doc="two-way system losses")
    method = Param(
        "covariance",
        type="str",
        choices=("covariance", "monte_carlo"),
        doc="time series: covariance (paper eq. 13-18) or monte_carlo (eq. 5-12, drops)",
    )
    drops_per_cell = Param(
        256, type="int", min=1, max=100_000, doc="drops per truth cell (monte_carlo only)"
    )
    support_db = Param(
        -100.0,
        units="dB",
        min=-200.0,
        max=0.0,
        doc="ignore truth radials whose two-way weight is below this level",
    )

    transient = ("_prepared",)

    def setup(self) -> None:
        self._prepared: tuple[Any, Any] | None = None

    def _prepare(
        self, truth: xr.Dataset, pad: int, k0: float, prt: float, lam: float, pulses: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, CellModel]:
        """Per-cell powers and moments, padded in range with the edge gates."""

        def padded(a: np.ndarray) -> np.ndarray:
            return np.pad(a, ((0, 0), (pad, pad)), mode="edge")

        rng_m = truth["range"].values
        r2 = padded(np.broadcast_to(rng_m**2, truth["DBZH"].shape))
        dbz = padded(truth["DBZH"].values)
        # A gate at zero range (some legacy files start there) holds no echo volume.
        echo = np.isfinite(dbz) & (r2 > 0)
        # W per (sr m) before pattern and range weighting.
        s_h = np.where(
            echo, k0 * 10 ** (np.nan_to_num(dbz, nan=-999.0) / 10) / np.where(echo, r2, 1.0), 0.0
        )
        field = {k: padded(_filled(truth, k, np.isfinite(truth["DBZH"].values))) for k in FILL}
        zdr = 10 ** (np.clip(field["ZDR"], -8, 8) / 10)
        rho = np.clip(field["RHOHV"], 0.0, 1.0)
        cells = CellModel(
            self.p["method"], field, rho, echo, prt, lam, pulses, self.p["drops_per_cell"]
        )
        return s_h, s_h / zdr, echo, cells

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        truth, beams = inputs["truth"], inputs["beams"]
        pattern, response = inputs["pattern"], inputs["range_response"]
        lam = SPEED_OF_LIGHT / self.p["frequency_hz"]
        prt = float(beams["prt"].values[0])
        pulses = int(beams["pulses"].values)
        rng_m = truth["range"].values
        gate_m = float(truth.attrs["gate_width_m"])
        width_deg = float(truth.attrs["radial_width_deg"])
        az_truth = truth["azimuth"].values

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
        k_off, r_k = range_weights(response, gate_m)

        # The truth is padded in range with its edge gates (the weather is taken to go on),
        # so the first and last gates see neighbours like every other gate.
        pad = int(np.max(np.abs(k_off)))
        n_b, n_g = beams.sizes["beam"], rng_m.size

        # What depends only on the truth is prepared once and reused by every chunk (and, with
        # threads, by every thread): it is a pure function of the inputs, memoised.
        key = (id(truth), pad, k0, prt, lam, pulses)
        if self._prepared is None or self._prepared[0] != key:
            self._prepared = (key, self._prepare(truth, pad, k0, prt, lam, pulses))
        s_h, s_v, echo, cells = self._prepared[1]

        d_az = pattern["azimuth_offset_deg"].values
        d_el = pattern["elevation_offset_deg"].values
        support = max(abs(d_az[0]), abs(d_az[-1])) + width_deg / 2
        iq = np.zeros((n_b, n_g, pulses, 2), np.complex64)
        power = np.zeros((n_b, n_g, 2), np.float64)
        for i, beam in enumerate(chunk.beams):
            gen = chunk.rng(int(beam))
            az_b = float(beams["azimuth"].values[i])
            el_b = float(beams["elevation"].values[i])
            delta = circular_difference(az_truth, az_b, 360.0)
            near = np.flatnonzero(np.abs(delta) <= support)
            profile = azimuth_profile(pattern["power"].values[i], d_el, el_b)
            omega = cell_solid_angles(profile, d_az, delta[near], width_deg)
            keep = omega.max(axis=0) >= omega.max() * 10 ** (self.p["support_db"] / 10)
            near, omega = near[keep], omega[:, keep]
            cell_power = np.stack([omega[0] @ s_h[near], omega[1] @ s_v[near]])
            # Cells ordered by gate, then radial, so that each gate's sum is one segment.
            gg, jj = np.nonzero(echo[near].T)
            volts = np.zeros((2, n_g + 2 * pad, pulses), np.complex64)
            if gg.size:
                rows = near[jj]
                h, v = cells.draw(rows, gg, gen)
                a_h = np.sqrt(s_h[rows, gg] * omega[0, jj]).astype(np.float32)[:, None]
                a_v = np.sqrt(s_v[rows, gg] * omega[1, jj]).astype(np.float32)[:, None]
                starts = np.flatnonzero(np.diff(gg, prepend=-1))
                volts[0, gg[starts]] = np.add.reduceat(a_h * h, starts, axis=0)
                volts[1, gg[starts]] = np.add.reduceat(a_v * v, starts, axis=0)
            for k, rk in zip(k_off, r_k, strict=True):
                window = slice(pad + k, pad + k + n_g)
                iq[i] += np.moveaxis(np.sqrt(rk) * volts[:, window], 0, -1)
                power[i] += rk * cell_power[:, window].T

        omega_bs = np.array([pattern.attrs[f"two_way_solid_angle_sr_{p}"] for p in POLARIZATIONS])
        constant_db = 10 * np.log10(k0 * omega_bs * r_k.sum())
        calibration = xr.Dataset(
            {
                "radar_constant_db": (
                    ("beam", "polarization"),
                    np.broadcast_to(constant_db, (n_b, 2)).copy(),
                )
            },
            coords={"range": ("range", rng_m), "polarization": list(POLARIZATIONS)},
            attrs={"wavelength_m": lam, "prt_s": prt},
        )
        return {"iq": iq, "signal_power": power.astype(np.float32), "calibration": calibration}


def _filled(truth: xr.Dataset, name: str, echo: np.ndarray) -> np.ndarray:
    if name not in truth:
        return np.full(echo.shape, FILL[name])
    values = truth[name].values.astype(np.float64)
    return np.where(np.isfinite(values), values, FILL[name])
