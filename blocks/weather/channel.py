"""The weather channel: truth cells -> dual-polarisation echo time series at every gate."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import POLARIMETRIC_FIELDS

from ..propagation.path import (
    PropagationParams,
    note,
    propagate,
    propagation_on,
    propagation_problems,
)
from ..signals import (
    BEAMS,
    CALIBRATION,
    CORRELATION_PRODUCTS,
    ECHO_CORRELATIONS,
    IQ,
    KW2,
    PATTERN,
    RANGE_RESPONSE,
    SHV_PRODUCTS,
    SIGNAL_POWER,
    SPEED_OF_LIGHT,
    TRUTH,
)
from ..timing import fine_grid, prt_ratio
from ..truth.volume import is_volume
from .beams import BeamDraw, weighted_cells
from .cells import TruthCells, flat_volume
from .chunk_setting import ChunkSetting
from .combined import draw_combined, draw_combined_coupled, draw_tones, draw_tones_coupled
from .coverage import check_coverage
from .dsd import DropSizes
from .expected import expected_correlations, expected_correlations_coupled
from .fasttime import RangeModel, range_correlate, range_model
from .motion import moving, platform_broadening, shift_echo
from .per_cell import draw_per_cell, draw_per_cell_coupled
from .polarimetry import (
    MODES,
    receive_channels,
)
from .power import radar_calibration
from .trips import fold_echo
from .width import WidthParams, radar_widths, scan_broadening

#: Fidelity levels of the weather channel, fastest first.
METHODS = ("expected", "combined", "covariance", "monte_carlo")
_COVARIANCE = {"method": "covariance", "support_db": -100.0}


class WeatherChannel(PropagationParams, WidthParams, Block):
    """Echoes of the truth cells around each beam, at one of four fidelity levels.

    Every truth cell with echo inside the pattern grid is an independent Gaussian scatterer
    ensemble with a Gaussian Doppler spectrum (mean velocity, spectrum width), and H and V
    returns S_hh = V1, S_vv = [rho V1 + sqrt(1 - rho^2) V2] exp(j phi_DP) / sqrt(Z_dr). Each
    cell is weighted by the two-way H or V pattern integrated over its azimuth extent and all
    elevations (the truth is one sweep, taken as uniform in elevation). In range, a cell is a
    continuum of sub-gate scatterers seen through the radiated pulse (with its Doppler phase
    along the pulse) and the receive filter, at every gate the range response reaches, range
    sidelobes included (:mod:`pasim_blocks.weather.fasttime`). Powers come from the radar equation,
    so a uniform field of Z dBZ gives back Z through the calibration output. The levels
    (``method``), fastest first:

    - ``expected``: no random draw. The echo's expected correlations (lag 0 and 1 of H and V,
      lag-0 H-V) through the beam and the range response's power (at each cell's velocity);
      the I/Q cube has no pulses and the pulse-pair processor estimates from
      ``echo_correlations``: the smoothing error alone. The level is declared
      (``fidelity_param``, ``expected_level``): the engine hands it to every block as
      ``Chunk.expected``, which the blocks downstream decide on.
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
    the two-way coupling M of those fields (:mod:`pasim_blocks.weather.polarimetry`): their
    covariance, the integral over the cell's directions of M C_s M^H, is used at every level
    (the expected correlations; the combined level's spectral matrix, 2 x 2 in SHV, 4 x 4 in
    AHV for the stacked channels of both transmit states, each pulse keeping its state's
    pair; the per-cell levels' Cholesky factor of each cell's channel covariance applied to
    independent unit series of its spectrum). So cross-polarisation biases ZDR, rho_hv and
    phi_DP as in a real radar. Without those fields (pencil and ideal antennas, or
    ``cross_polar_coupling`` off) H and V are weighted by the squared co-polar power patterns
    and their cross term by sqrt(Omega_H Omega_V) (exact for proportional patterns).

    Spectrum widths (``width_model``): a radar file's widths are taken as that radar's
    measurement and corrected to what this radar would see (:mod:`pasim_blocks.weather.width`).

    Propagation (``propagation``): at a frequency in another band than the truth's, the cells
    are seen through the path's two-way rain and gaseous attenuation and the differential
    phase at this frequency, from the truth's KDP (:mod:`pasim_blocks.propagation`); the
    calibration then carries the two-way attenuation along each beam's axis.

    A moving platform (the beams' ``platform_radial_velocity``,
    :mod:`pasim_blocks.weather.motion`): each cell's radial velocity is relative to the radar
    (the platform's velocity along the beam subtracted), and the platform's motion across the
    beam widens the spectrum by Doviak and Zrnic's 0.3 v_perp theta_1, with the beam's own
    widths measured on its pattern.

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
    drop_sizes = Param(
        "equal",
        type="str",
        choices=("equal", "gamma"),
        doc="monte_carlo drops: equal (rho_hv from random backscatter phases, eq. 5-12) or "
        "gamma (a constrained-gamma size distribution fitted per cell to Z and ZDR; ZDR, "
        "rho_hv and PHIDP from the drops, see pasim_blocks.weather.dsd); the other levels "
        "ignore it, as they ignore drops_per_cell",
    )
    temperature_c = Param(
        10.0,
        units="degC",
        min=-10.0,
        max=40.0,
        doc="temperature of the rain drops (water permittivity; drop_sizes gamma only)",
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
    support_fraction = Param(
        1e-3,
        min=0.0,
        max=0.1,
        doc="scene-aware support of the per-cell levels (covariance, monte_carlo): per gate, "
        "leave undrawn the weakest truth cells whose summed expected echo power is at most "
        "this fraction of the gate's, so that each gate's expected power is low by at most "
        "this fraction (1e-3: 0.0043 dB); 0 draws every cell. combined draws every cell",
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
    range_folding = Param(
        True,
        type="bool",
        doc="add the echoes of earlier pulses from beyond the unambiguous range c T / 2 "
        "(multiple trips); false: every echo first-trip",
    )
    elevation_support_db = Param(
        -60.0,
        units="dB",
        min=-200.0,
        max=0.0,
        doc="volume truth: elevation offsets where the two-way pattern, integrated over "
        "azimuth, is below this level from its peak read no truth sweep",
    )
    cross_polar_coupling = Param(
        True,
        type="bool",
        doc="couple H and V through the antenna's complex co- and cross-polar fields when the "
        "pattern has them (false: co-polar power patterns only)",
    )

    # Fastest first, most faithful last; ``pasim tradeoff`` runs them all. -40 dB keeps the
    # main lobe and first sidelobes of a -32 dB antenna and drops the far ones; covariance
    # leaves undrawn the weakest cells summing to 0.1 % of each gate's echo, covariance-all
    # draws them all.
    # The study's reference runs read these, not the parameter's name.
    fidelity_param = "method"
    expected_level = "expected"
    fidelity_ladder = (
        ("expected", {"method": "expected", "support_db": -100.0, "precision": "float64"}),
        ("combined-40dB", {"method": "combined", "support_db": -40.0, "precision": "float32"}),
        ("combined", {"method": "combined", "support_db": -100.0, "precision": "float32"}),
        ("combined-f64", {"method": "combined", "support_db": -100.0, "precision": "float64"}),
        ("covariance", {**_COVARIANCE, "support_fraction": 1e-3, "precision": "float32"}),
        ("covariance-all", {**_COVARIANCE, "support_fraction": 0.0, "precision": "float32"}),
        ("covariance-f64", {**_COVARIANCE, "support_fraction": 0.0, "precision": "float64"}),
        ("monte_carlo", {"method": "monte_carlo", "support_db": -100.0, "precision": "float32"}),
    )

    transient = ("_prepared", "_path")

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        return propagation_problems(params)

    def setup(self) -> None:
        self._prepared: tuple[Any, Any] | None = None
        self._path: tuple[int, Any] | None = None

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        truth, beams = inputs["truth"], inputs["beams"]
        pattern, response = inputs["pattern"], inputs["range_response"]
        run = self._run(truth, beams, pattern, chunk)
        broadening = scan_broadening(beams, pattern, run.lam, self.p["antenna_motion"])
        # On a moving platform, the motion across the beam widens each beam's spectrum.
        broadening = platform_broadening(beams, pattern, broadening)
        path = self._propagated(truth, run.volume)
        iq, corr, ranges = self._echoes(run, inputs, chunk, broadening, path)
        iq, corr, overlay = self._received(run, iq, corr, beams, response)
        calibration = radar_calibration(run, self.p["peak_power_w"], inputs, ranges, path, overlay)
        power = corr[..., :2].real.astype(np.float32)
        return {
            "iq": np.moveaxis(iq.astype(np.complex64, copy=False), 1, -1),
            "signal_power": power,
            "echo_correlations": corr,
            "calibration": calibration,
        }

    def _run(
        self, truth: xr.Dataset, beams: xr.Dataset, pattern: xr.Dataset, chunk: Chunk
    ) -> ChunkSetting:
        """What every beam of the chunk shares: the radar's and the truth's geometry, the
        channels drawn, and the radar equation's constant."""
        method = self.p["method"]
        dtype = np.float32 if self.p["precision"] == "float32" else np.float64
        lam = SPEED_OF_LIGHT / self.p["frequency_hz"]
        prt = prt_t1 = float(beams["prt"].values[0])
        pulses = int(beams["pulses"].values)
        staggered = _staggered_grid(beams, method, self.p["transmission"])
        if staggered is not None:
            # The series are drawn on a uniform grid of step u (T1 = a u, T2 = b u) and
            # sampled at the pulse times.
            prt, pulses = staggered[0], int(staggered[1][-1]) + 1
        dual = all(k in truth for k in POLARIMETRIC_FIELDS)
        mode = self.p["transmission"]
        # AHV estimates velocity from the H and V co-polar pulses together (processor).
        need_v = dual and (
            chunk.wants(*POLARIMETRIC_FIELDS) or (mode == "ahv" and chunk.wants("VRADH", "WRADH"))
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
        return ChunkSetting(
            method=method,
            dtype=dtype,
            lam=lam,
            prt=prt,
            prt_t1=prt_t1,
            pulses=pulses,
            staggered=staggered,
            rng_m=truth["range"].values,
            gate_m=float(truth.attrs["gate_width_m"]),
            width_deg=float(truth.attrs["radial_width_deg"]),
            az_truth=truth["azimuth"].values,
            dual=dual,
            mode=mode,
            beta=float(self.p["transmit_differential_phase_deg"]),
            need_v=need_v,
            coupled=bool(self.p["cross_polar_coupling"])
            and all(k in pattern for k in ("co_polar", "cross_polar")),
            k0=k0,
            volume=is_volume(truth),
            drawn=0 if method == "expected" else len(receive_channels(mode, need_v)),
        )

    def _cells(
        self,
        run: ChunkSetting,
        truth: xr.Dataset,
        response: xr.Dataset,
        path: tuple[xr.Dataset, Any] | None,
        beam_broadening: float,
    ) -> tuple[RangeModel, TruthCells]:
        """The range model and the prepared truth cells for a beam's scan modulation. What
        depends only on the truth, the range response and the beam's own scan modulation is
        prepared once and reused by every beam and chunk that share them (and, with threads,
        by every thread): a pure function of the inputs, memoised."""
        gamma = self.p["drop_sizes"] == "gamma" and run.method == "monte_carlo"
        key: tuple[Any, ...] = (id(truth), id(response), run.k0, run.prt, run.lam, run.pulses)
        key += (run.method,)
        key += (run.dtype, self.p["range_support_db"], self.p["drops_per_cell"])
        key += (gamma, self.p["temperature_c"], float(beam_broadening))
        if self._prepared is None or self._prepared[0] != key:
            # A volume truth: the cells of every sweep, sweep-major (row s x radials + j).
            seen = flat_volume(truth) if run.volume else truth
            if path is not None:
                seen = path[0]
            ranges = range_model(
                response,
                run.gate_m,
                run.lam,
                _largest_speed(seen),
                floor_db=self.p["range_support_db"],
            )
            sizes = (
                DropSizes.build(self.p["frequency_hz"], self.p["temperature_c"]) if gamma else None
            )
            cells = TruthCells(
                radar_widths(seen, self.widths(), float(beam_broadening)),
                ranges,
                run.k0,
                run.prt,
                run.lam,
                run.pulses,
                run.method,
                self.p["drops_per_cell"],
                run.dtype,
                sizes,
            )
            self._prepared = (key, (ranges, cells))
        return self._prepared[1]

    def _echoes(
        self,
        run: ChunkSetting,
        inputs: dict[str, Any],
        chunk: Chunk,
        broadening: np.ndarray,
        path: tuple[xr.Dataset, Any] | None,
    ) -> tuple[np.ndarray, np.ndarray, RangeModel]:
        """Each beam's expected correlations and, at every level but ``expected``, its drawn
        echo series: the I/Q (beam x polarisation x gate x pulse, on the drawing grid), the
        correlations (beam x gate x product) and the range model."""
        truth, beams = inputs["truth"], inputs["beams"]
        pattern, response = inputs["pattern"], inputs["range_response"]
        ranges, cells = self._cells(
            run, truth, response, path, broadening[0] if broadening.size else 0.0
        )
        d_az = pattern["azimuth_offset_deg"].values
        support = max(abs(d_az[0]), abs(d_az[-1])) + run.width_deg / 2
        check_coverage(
            run.az_truth, run.width_deg, beams["azimuth"].values, support - run.width_deg / 2
        )
        n_b, n_g = beams.sizes["beam"], run.rng_m.size
        cdtype = np.complex64 if run.dtype == np.float32 else np.complex128
        # Stored polarisation-major, handed on as a (beam, range, pulse, polarization) view:
        # each channel's series stay contiguous for the draws and for the blocks downstream.
        iq = np.zeros((n_b, 2, n_g, 0 if run.method == "expected" else run.pulses), cdtype)
        corr = np.zeros((n_b, n_g, len(CORRELATION_PRODUCTS)), np.complex128)
        # Beams of equal scan modulation one after another: their cells are prepared once.
        for i in np.argsort(broadening, kind="stable"):
            ranges, cells = self._cells(run, truth, response, path, broadening[i])
            near, omega, coupling = weighted_cells(
                run,
                truth,
                beams,
                pattern,
                i,
                support,
                self.p["support_db"],
                self.p["elevation_support_db"],
            )
            cells.prepare(near)
            terms = ranges.power.shape[0]
            alternate = run.mode == "ahv"
            expected = (
                expected_correlations(cells, near, omega, terms, alternate)
                if coupling is None
                else expected_correlations_coupled(cells, near, coupling, terms, alternate)
            )
            corr[i] = range_correlate(expected, ranges.power.T, n_g, exact=True)
            if not alternate:
                corr[i, :, len(SHV_PRODUCTS) :] = np.nan
            if coupling is None and run.mode == "shv" and run.beta:
                # The V port's echo carries the transmit differential phase.
                corr[i] *= _beta_factors(run.beta)
            if run.method == "expected" or near.size == 0:
                continue
            beam = int(chunk.beams[i])
            draw = BeamDraw(
                cells,
                near,
                omega,
                ranges,
                chunk.rng(beam),
                chunk.rng(beam, 1),
                run.need_v,
                coupling,
                run.drawn,
                run.mode,
                self.p["support_fraction"] if run.method != "combined" else 0.0,
            )
            _draw(iq[i], draw, run, coupling is not None)
        return iq, corr, ranges

    def _received(
        self,
        run: ChunkSetting,
        iq: np.ndarray,
        corr: np.ndarray,
        beams: xr.Dataset,
        response: xr.Dataset,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The echoes as the receiver gets them: a staggered scan's pulses taken from the
        drawing grid, the trips folded (with the other trips' power over the gate's own, dB,
        or None), the platform's approach, nothing inside the blind range."""
        if run.staggered is not None:
            iq = iq[..., run.staggered[1]]
        folded = fold_echo(
            iq, corr, beams, run.rng_m, run.gate_m, run.method, self.p["range_folding"]
        )
        overlay = None
        if folded is not None:
            iq, corr, overlay = folded
        if moving(beams):
            # Every cell approached at the platform's velocity along the beam.
            times = (
                run.staggered[1] * run.staggered[0]
                if run.staggered is not None
                else np.arange(iq.shape[-1]) * run.prt_t1
            )
            shift_echo(iq, corr, beams, times, run.prt_t1, run.lam)
        # The receiver is off while the pulse goes out: nothing is received inside the blind
        # range (the processor masks those gates and the scorer never scores them).
        blind = run.rng_m < float(response.attrs["blind_range_m"])
        iq[:, :, blind] = 0
        corr[:, blind] = 0
        return iq, corr, overlay

    def _propagated(self, truth: xr.Dataset, volume: bool) -> tuple[xr.Dataset, Any] | None:
        """The truth cells (a volume's flattened) through the path and the path, when
        propagation is on (None when off); computed once per truth."""
        if not propagation_on(self.p):
            return None
        note(self.p)
        if self._path is None or self._path[0] != id(truth):
            seen = flat_volume(truth) if volume else truth
            if volume:
                elevation = np.repeat(truth["sweep_elevation"].values, truth.sizes["radial"])
            else:
                elevation = np.full(truth.sizes["radial"], float(truth.attrs["elevation_deg"]))
            self._path = (id(truth), propagate(seen, elevation, self.p))
        return self._path[1]


def _staggered_grid(
    beams: xr.Dataset, method: str, transmission: str
) -> tuple[float, np.ndarray] | None:
    """The uniform grid step and the pulses' indices on it of a staggered scan (None when
    the PRT is uniform)."""
    ratio = prt_ratio(beams)
    if ratio is None:
        return None
    if method == "expected" or transmission != "shv":
        raise ValueError(
            "a staggered PRT needs time series in simultaneous transmission: method "
            f"{method!r} and transmission {transmission!r} (use combined, covariance or "
            "monte_carlo, and shv)"
        )
    return fine_grid(float(beams["prt"].values[0]), int(beams["pulses"].values), ratio)


def _largest_speed(truth: xr.Dataset) -> float:
    """The largest |radial velocity| of a cell with echo (0 without velocities)."""
    if "VRADH" not in truth:
        return 0.0
    v = np.abs(truth["VRADH"].values[np.isfinite(truth["DBZH"].values)])
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else 0.0


def _beta_factors(beta_deg: float) -> np.ndarray:
    """Factors on the correlation products when the V port's echo is multiplied by e^(j beta)."""
    t = np.exp(1j * np.deg2rad(beta_deg))
    factors = {"R0_HV": t, "R1_HV": t, "R1_VH": np.conj(t)}
    return np.array([factors.get(k, 1.0) for k in CORRELATION_PRODUCTS])


def _draw(iq: np.ndarray, draw: BeamDraw, run: ChunkSetting, coupled: bool) -> None:
    """Add one beam's drawn echo series to ``iq`` (polarisation x gate x pulse): at the
    combined level the gates' spectral draws and the tones, then the cells drawn one by one."""
    if coupled:
        if run.method == "combined":
            draw_combined_coupled(iq, draw)
            draw_tones_coupled(iq, draw)
        draw_per_cell_coupled(iq, draw)
        return
    if run.method == "combined":
        draw_combined(iq, draw)
        draw_tones(iq, draw)
    draw_per_cell(iq, draw)
    if run.mode == "shv" and run.beta:
        cdtype = np.complex64 if run.dtype == np.float32 else np.complex128
        iq[1] *= np.exp(1j * np.deg2rad(run.beta)).astype(cdtype)
    elif run.mode == "ahv":
        # Without cross-polar fields a port receives nothing of the other polarisation's
        # pulses.
        iq[0, :, 1::2] = 0
        iq[1, :, 0::2] = 0
