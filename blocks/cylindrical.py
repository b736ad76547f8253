"""A cylindrical polarimetric phased array (CPPAR) with commutated beams.

Columns of dual-polarised patches stand around a vertical cylinder, each patch facing along
the cylinder's outward normal at its column. A beam is formed by a sector of adjacent columns
centred on the beam azimuth; the sector moves round the cylinder a column at a time
(commutation), so every beam sees the same geometry up to the beam's offset from the sector
centre, a fraction of one column spacing. The pattern is therefore nearly the same at every
azimuth, unlike a planar face whose beam broadens and loses gain off broadside.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from .antenna import (
    PATCH_SIDE,
    PATTERN_SUPPORT,
    offsets,
    pattern_dataset,
    two_way_solid_angle,
)
from .signals import BEAMS, PATTERN, POLARIZATIONS

# Samples per column spacing of the full-circle azimuth grid used for the directivity
# integral: 4 gives 2496 samples round a 624-column cylinder, twice the highest angular
# harmonic (2 k R ~ 590) of the power pattern, so the periodic trapezoid rule is exact.
_FULL_CIRCLE_PER_COLUMN = 4
# Direction-sine samples of the azimuth-integrated power I(v) (a smooth function of v, cubic
# spline between them) and of the vertical array factor (a trig polynomial of degree N - 1).
_V_COARSE = 401
_V_FINE = 40_001


def taylor_continuous(x: np.ndarray, n: int, sll_db: float, nbar: int) -> np.ndarray:
    """scipy's Taylor window of ``n`` samples, evaluated at any aperture position.

    ``scipy.signal.windows.taylor`` samples ``w(x) = 1 + 2 sum_m F_m cos(2 pi m x)`` at the
    cell centres ``x = (i - n/2 + 1/2) / n`` of an aperture running from -1/2 to 1/2. The
    ``F_m`` are read back from scipy's own samples (an exact linear fit: ``nbar`` cosines,
    ``n >= nbar`` samples), so that ``w`` can be evaluated at non-uniform positions such as a
    cylinder's projected column positions. Normalised to 1 at ``x = 0``.
    """
    from scipy.signal import windows

    size = max(n, 4 * nbar + 1)
    samples = windows.taylor(size, nbar=nbar, sll=abs(sll_db), norm=False)
    cells = (np.arange(size) - size / 2 + 0.5) / size
    m = np.arange(nbar)
    coeffs, *_ = np.linalg.lstsq(np.cos(2 * np.pi * np.outer(cells, m)), samples, rcond=None)
    w = np.cos(2 * np.pi * np.outer(np.asarray(x, dtype=float), m)) @ coeffs
    return np.asarray(w / coeffs.sum())


class CylindricalArray(Block):
    """A cylindrical array of dual-polarised patches with commutated beams (CPPAR).

    ``columns`` columns stand on a circle of ``diameter_m``; each holds
    ``elements_per_column`` patches ``spacing_y_m`` apart, facing along the column's own
    outward normal (the patch element of ``antenna.planar``). A beam is formed by the
    ``excited_columns`` adjacent columns centred on the beam azimuth, Taylor-tapered across
    the sector and along the column, and phase-steered to the beam's azimuth and elevation.
    The array factor sums over the columns' real positions on the circle. The H and V
    co-polar patterns differ (the patch's E- and H-plane patterns weight the sector edges
    differently), but the difference is nearly the same for every beam, so the calibration
    removes it. Patterns are normalised to the H peak of a beam on the sector centre at 0 deg
    elevation; ``gain_db`` is that beam's H directivity from the full-sphere pattern integral.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V power patterns around each beam axis")

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    diameter_m = Param(10.0, units="m", min=0.1, max=100.0, doc="cylinder diameter")
    columns = Param(624, type="int", min=3, max=100_000, doc="columns round the cylinder")
    excited_columns = Param(
        156, type="int", min=1, max=100_000, doc="adjacent columns that form one beam"
    )
    elements_per_column = Param(128, type="int", min=1, max=4096, doc="patches per column")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    patch_m = PATCH_SIDE
    taylor_sll_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor sidelobe level across the sector"
    )
    taylor_nbar = Param(5, type="int", min=1, max=50, doc="Taylor nbar across the sector")
    taper_axis = Param(
        "columns",
        type="str",
        choices=("columns", "projected"),
        doc="sample the sector taper per column (arc) or at the projected positions",
    )
    taylor_sll_y_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor sidelobe level along the column"
    )
    taylor_nbar_y = Param(5, type="int", min=1, max=50, doc="Taylor nbar along the column")
    first_column_azimuth_deg = Param(
        0.0, units="deg", min=0.0, max=360.0, doc="azimuth of column 0's outward normal"
    )
    support_deg = PATTERN_SUPPORT
    grid_step_deg = Param(
        0.05,
        units="deg",
        min=0.001,
        max=1.0,
        doc="pattern grid step (azimuth: rounded down to a divisor of the column spacing)",
    )

    transient = ("_memo",)

    @classmethod
    def warm_up(cls) -> None:
        from . import patterns  # noqa: F401

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        def get(name: str) -> Any:
            return params.get(name, cls.params[name].default)

        columns, excited = get("columns"), get("excited_columns")
        if not (isinstance(columns, int) and isinstance(excited, int)):
            return []
        if excited > columns:
            return [
                (
                    "parameter 'excited_columns'",
                    f"{excited} is more than the {columns} columns round the cylinder",
                )
            ]
        if get("taper_axis") == "projected" and 2 * excited >= columns:
            return [
                (
                    "parameter 'taper_axis'",
                    "'projected' needs a sector narrower than 180 deg "
                    f"({excited} of {columns} columns)",
                )
            ]
        return []

    # ---- set-up -----------------------------------------------------------------------------

    def setup(self) -> None:
        from .patterns import SPEED_OF_LIGHT, taylor_taper

        p = self.p
        self.k = 2 * np.pi * p["frequency_hz"] / SPEED_OF_LIGHT
        self.radius_m = p["diameter_m"] / 2
        self.column_step_deg = 360.0 / p["columns"]
        # The azimuth grid step divides the column spacing, so that every direction of the grid
        # sits the same whole number of steps from every column: the sum over columns is then a
        # discrete convolution (exact, by FFT) of one column's field sampled once per row.
        self.per_column = int(np.ceil(self.column_step_deg / p["grid_step_deg"] - 1e-9))
        self.az_step_deg = self.column_step_deg / self.per_column
        self.d_az = offsets(p["support_deg"], self.az_step_deg)
        self.d_el = offsets(p["support_deg"], p["grid_step_deg"])
        n = p["excited_columns"]
        # Column azimuths relative to the sector centre (between two columns when n is even).
        self.sector_deg = (np.arange(n) - (n - 1) / 2) * self.column_step_deg
        self.amplitude = self._sector_taper()
        m = p["elements_per_column"]
        self.z_m = (np.arange(m) - (m - 1) / 2) * p["spacing_y_m"]
        self.taper_y = taylor_taper(m, p["taylor_sll_y_db"], p["taylor_nbar_y"])
        # Reference: the in-phase sum of a beam on the sector centre at 0 deg elevation, H port.
        e_h, _ = self._element(-self.sector_deg, np.zeros(1))
        self.norm = float(np.sum(self.amplitude * e_h[0])) * float(np.sum(self.taper_y))
        self._memo: dict[tuple[int, float], np.ndarray] | None = {}
        reference = self._power(0, 0.0)
        self.omega = {
            pol: two_way_solid_angle(reference[i], self.d_az, self.d_el, 0.0)
            for i, pol in enumerate(POLARIZATIONS)
        }
        integral = self._sphere_integral()
        self.directivity_db = {
            pol: float(10 * np.log10(4 * np.pi * reference[i].max() / integral[i]))
            for i, pol in enumerate(POLARIZATIONS)
        }
        self.gain_db = float(10 * np.log10(4 * np.pi / integral[0]))

    def _sector_taper(self) -> np.ndarray:
        from .patterns import taylor_taper

        p = self.p
        n = p["excited_columns"]
        if p["taper_axis"] == "columns":
            return taylor_taper(n, p["taylor_sll_db"], p["taylor_nbar"])
        # Taylor over the projected aperture: positions on the chord through the sector edges.
        half = np.deg2rad(n * self.column_step_deg / 2)
        if half >= np.pi / 2:
            raise ValueError("taper_axis 'projected' needs a sector narrower than 180 deg")
        x = np.sin(np.deg2rad(self.sector_deg)) / (2 * np.sin(half))
        return taylor_continuous(x, n, p["taylor_sll_db"], p["taylor_nbar"])

    # ---- fields -------------------------------------------------------------------------------

    def _element(self, delta_deg: np.ndarray, el_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """H and V co-polar fields of one patch, ``delta_deg`` off its normal: (el, delta)."""
        from .patterns import patch_element_field

        field = patch_element_field(
            np.asarray(delta_deg)[None, :],
            np.asarray(el_deg)[:, None],
            patch_m=self.p["patch_m"],
            frequency_hz=self.p["frequency_hz"],
        )
        shape = (np.size(el_deg), np.size(delta_deg))
        return np.broadcast_to(field.h_co, shape), np.broadcast_to(field.v_co, shape)

    def _column_field(
        self, delta_deg: np.ndarray, el_deg: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """One column's H and V horizontal field, ``delta_deg`` off its normal: (el, delta).

        Element field times the path phase ``k R cos(el) cos(delta)`` of a column on the
        circle (the column's vertical array factor is applied separately).
        """
        e_h, e_v = self._element(delta_deg, el_deg)
        phase = np.exp(
            1j
            * self.k
            * self.radius_m
            * np.cos(np.deg2rad(el_deg))[:, None]
            * np.cos(np.deg2rad(delta_deg))[None, :]
        )
        return e_h * phase, e_v * phase

    def _weights(self, offset_deg: float, el_deg: float) -> np.ndarray:
        """Sector weights steering to ``offset_deg`` from the sector centre, ``el_deg`` up."""
        steer = np.deg2rad(offset_deg - self.sector_deg)
        path = self.k * self.radius_m * np.cos(np.deg2rad(el_deg)) * np.cos(steer)
        return self.amplitude * np.exp(-1j * path)

    def _vertical_factor(self, sin_el: np.ndarray, steer_el_deg: float) -> np.ndarray:
        """Array factor of one column (Taylor, phase-steered), shape of ``sin_el``."""
        psi = self.k * (np.asarray(sin_el) - np.sin(np.deg2rad(steer_el_deg)))
        return np.exp(1j * np.multiply.outer(psi, self.z_m)) @ self.taper_y

    def _power(self, step: int, el_deg: float) -> np.ndarray:
        """H and V power, (2, el, az), of the beam ``step`` azimuth steps off the sector centre.

        The grid directions sit at ``(step + i) * az_step`` from the sector centre and the
        columns at multiples of ``per_column`` steps (plus half a column for an even sector),
        so the column sum is a correlation along azimuth, done by FFT for every row at once.
        """
        from scipy.signal import fftconvolve

        if self._memo is None:  # dropped when the block was pickled to a worker
            self._memo = {}
        key = (step, round(el_deg, 9))
        if key in self._memo:
            return self._memo[key]
        n, per = self.p["excited_columns"], self.per_column
        half_span = (self.d_az.size - 1) // 2
        count = self.d_az.size + (n - 1) * per
        # Column j sees grid direction i (0 .. 2 half_span) at delta = base + (i + q) * s with
        # q = (n - 1 - j) * per, so the row sum over j is a 'valid' convolution with the
        # weights spread ``per`` samples apart.
        base = (step - half_span - (n - 1) * per / 2) * self.az_step_deg
        delta = base + np.arange(count) * self.az_step_deg
        el = el_deg + self.d_el
        f_h, f_v = self._column_field(delta, el)
        kernel = np.zeros((1, (n - 1) * per + 1), complex)
        kernel[0, ::per] = self._weights(step * self.az_step_deg, el_deg)
        vertical = self._vertical_factor(np.sin(np.deg2rad(el)), el_deg)[:, None]
        out = np.empty((2, self.d_el.size, self.d_az.size), np.float32)
        for i, f in enumerate((f_h, f_v)):
            field = vertical * fftconvolve(f, kernel, mode="valid", axes=1) / self.norm
            out[i] = field.real**2 + field.imag**2
        self._memo[key] = out
        return out

    def _sphere_integral(self) -> np.ndarray:
        """Integral of the reference beam's one-way H and V power over the sphere (sr).

        ``int dv int d(az) |A(v)|^2 |S(az, v)|^2`` with ``v = sin(el)``: the horizontal sum
        ``S`` round the whole circle is a circular convolution (exact trapezoid rule for a
        periodic band-limited integrand), its azimuth integral ``I(v)`` is smooth and is
        splined from a coarse ``v`` grid onto the fine grid of the vertical factor ``A(v)``.
        """
        from scipy.interpolate import CubicSpline

        per = _FULL_CIRCLE_PER_COLUMN
        n, columns = self.p["excited_columns"], self.p["columns"]
        size = columns * per
        step_deg = self.column_step_deg / per
        # Directions at (i + h) steps from the sector centre, h in {0, 1/2} making every column
        # offset a whole number of steps: column j sees direction i at (i + lag - j per) steps.
        lag = ((n - 1) * per / 2) % 1.0 + (n - 1) * per / 2
        delta = (np.arange(size) + lag) * step_deg
        v = np.linspace(-1.0, 1.0, _V_COARSE)
        el = np.rad2deg(np.arcsin(v))
        kernel = np.zeros(size, complex)
        kernel[np.arange(n) * per] = self._weights(0.0, 0.0)
        spectrum = np.fft.fft(kernel)
        profile = np.empty((2, v.size))
        for i, f in enumerate(self._column_field(delta, el)):
            s = np.fft.ifft(np.fft.fft(f, axis=1) * spectrum, axis=1) / self.norm
            profile[i] = np.sum(s.real**2 + s.imag**2, axis=1) * np.deg2rad(step_deg)
        v_fine = np.linspace(-1.0, 1.0, _V_FINE)
        vertical = np.abs(self._vertical_factor(v_fine, 0.0)) ** 2
        dv = v_fine[1] - v_fine[0]
        return np.array(
            [np.trapezoid(vertical * CubicSpline(v, prof)(v_fine), dx=dv) for prof in profile]
        )

    # ---- beams ----------------------------------------------------------------------------------

    def beam_offset_steps(self, azimuth_deg: float) -> int:
        """Offset of a beam from the nearest sector centre, in azimuth grid steps.

        Sector centres lie on a column (odd sector) or midway between two (even sector); the
        offset is within half a column spacing and is rounded to the azimuth grid step (at most
        half a step of pattern-shape error, no pointing error: the pattern is reported around
        the beam's own azimuth).
        """
        n = self.p["excited_columns"]
        first_centre = self.p["first_column_azimuth_deg"] + (n - 1) / 2 * self.column_step_deg
        rel = (azimuth_deg - first_centre) / self.column_step_deg
        offset_columns = rel - np.round(rel)
        return int(np.round(offset_columns * self.per_column))

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams"]
        power = np.stack(
            [
                self._power(self.beam_offset_steps(float(a)), float(e))
                for a, e in zip(beams["azimuth"].values, beams["elevation"].values, strict=True)
            ]
        )
        ds = pattern_dataset(
            power,
            self.d_az,
            self.d_el,
            self.gain_db,
            self.omega,
            antenna="cylindrical",
            directivity_h_db=self.directivity_db["H"],
            directivity_v_db=self.directivity_db["V"],
        )
        return {"pattern": ds}
