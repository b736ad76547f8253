"""A cylindrical polarimetric phased array (CPPAR) with commutated beams.

Columns of dual-polarised elements stand around a vertical cylinder, each element facing along
the cylinder's outward normal at its column. A beam is formed by a sector of adjacent columns
centred on the beam azimuth; the sector moves round the cylinder a column at a time
(commutation), so every beam sees the same geometry up to the beam's offset from the sector
centre, a fraction of one column spacing. The pattern is therefore nearly the same at every
azimuth, unlike a planar face whose beam broadens and loses gain off broadside. Each column is
fed by one dual-polarised T/R module (80 W per column in the paper), so the channel
electronics act per column: with random errors the commutated sectors differ, and so do their
patterns.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Param
from pasim_graph.memo import SHARED, state_key

from ..signals import POLARIZATIONS
from .array import ArrayAntenna, ideal_copy
from .base import (
    KAISER_BETA,
    PATTERN_SUPPORT,
    TAPER,
    offsets,
    steering,
    two_way_solid_angle,
)

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


class CylindricalArray(ArrayAntenna):
    """A cylindrical array of dual-polarised elements with commutated beams (CPPAR).

    ``columns`` columns stand on a circle of ``diameter_m``; each holds
    ``elements_per_column`` elements ``spacing_y_m`` apart, facing along the column's own
    outward normal. A beam is formed by the ``excited_columns`` adjacent columns centred on
    the beam azimuth, tapered across the sector (``taper``) and along the column (Taylor),
    and phase-steered to the beam's azimuth and elevation. The array factor sums over the
    columns' real positions on the circle. Each column is one T/R channel per port: the
    channel electronics (errors, failures, quantised phase shifters and attenuators) act on
    the column weights; the column's own vertical feed is ideal. The H and V co-polar
    patterns differ (the patch's E- and H-plane patterns weight the sector edges
    differently), but the difference is nearly the same for every beam. Patterns are
    normalised to the H peak of an ideal beam on the sector centre at 0 deg elevation;
    ``gain_db`` is that beam's H directivity from the full-sphere pattern integral.
    """

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    diameter_m = Param(10.0, units="m", min=0.1, max=100.0, doc="cylinder diameter")
    columns = Param(624, type="int", min=3, max=100_000, doc="columns round the cylinder")
    excited_columns = Param(
        156, type="int", min=1, max=100_000, doc="adjacent columns that form one beam"
    )
    elements_per_column = Param(128, type="int", min=1, max=4096, doc="elements per column")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    taper = TAPER
    taylor_sll_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor sidelobe level across the sector"
    )
    taylor_nbar = Param(5, type="int", min=1, max=50, doc="Taylor nbar across the sector")
    kaiser_beta = KAISER_BETA
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

    transient = ("_memo", "_draws", "_state")
    directivity_db: dict[str, float]  # per polarisation, set with the broadside figures

    @classmethod
    def warm_up(cls) -> None:
        super().warm_up()
        # Its pattern grids convolve along azimuth: scipy.signal, and the 420 modules it
        # pulls in, were imported by a worker's first chunk (0.55 s of CPU).
        import scipy.signal  # noqa: F401

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        out = super().check_config(params, connected)

        def get(name: str) -> Any:
            return params.get(name, cls.params[name].default)

        columns, excited = get("columns"), get("excited_columns")
        if not (isinstance(columns, int) and isinstance(excited, int)):
            return out
        if excited > columns:
            out.append(
                (
                    "parameter 'excited_columns'",
                    f"{excited} is more than the {columns} columns round the cylinder",
                )
            )
        elif get("taper_axis") == "projected" and 2 * excited >= columns:
            out.append(
                (
                    "parameter 'taper_axis'",
                    "'projected' needs a sector narrower than 180 deg "
                    f"({excited} of {columns} columns)",
                )
            )
        return out

    # ---- set-up -----------------------------------------------------------------------------

    def setup(self) -> None:
        from ..signals import SPEED_OF_LIGHT
        from .tapers import taylor_taper

        super().setup()
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
        self._memo: dict[tuple[int, int, float], np.ndarray] | None = {}
        self._state: str | None = None  # state_key, once prepared
        self._element_model: Any = None
        self.prepared = False
        if p["element"] != "file":
            self.prepare(None)

    def prepare(self, resource: Any) -> None:
        """Normalisation, broadside solid angles and gain (needs the element's pattern file)."""
        if self.prepared:
            return
        self._element_model = self.make_element(resource)
        # Reference: the in-phase sum of a beam on the sector centre at 0 deg elevation, H port.
        e = self._element(-self.sector_deg, np.zeros(1))
        self.norm = float(np.sum(self.amplitude * e[0][0].real)) * float(np.sum(self.taper_y))
        ideal = ideal_copy(self)
        if ideal is not self:
            # The broadside figures are the design's: the ideal array's, computed once.
            ideal.prepare(resource)
            self.omega, self.gain_db = ideal.omega, ideal.gain_db
            self.directivity_db = ideal.directivity_db
            self.prepared = True
            return
        # The design's figures depend on its state alone: a study's runs of one system (its
        # estimate, expected level and calibrations, every seed) each built a new array and
        # computed them again in the `pasim` process (0.2-0.4 s a run for the CPPARs).
        shared = (self._grid_state_key(), "broadside")
        figures = SHARED.get(shared)
        if figures is None:
            reference = np.abs(self._grid(-1, 0, 0.0, 0)[[0, 2]]) ** 2
            integral = self._sphere_integral()
            omega = [two_way_solid_angle(reference[i], self.d_az, self.d_el, 0.0) for i in (0, 1)]
            directivity = [
                10 * np.log10(4 * np.pi * reference[i].max() / integral[i]) for i in (0, 1)
            ]
            gain = 10 * np.log10(4 * np.pi / integral[0])
            figures = SHARED.put(shared, np.array([*omega, *directivity, gain], dtype=np.float64))
        self.omega = {pol: float(figures[i]) for i, pol in enumerate(POLARIZATIONS)}
        self.directivity_db = {pol: float(figures[2 + i]) for i, pol in enumerate(POLARIZATIONS)}
        self.gain_db = float(figures[4])
        self.prepared = True

    def _sector_taper(self) -> np.ndarray:
        from .tapers import design_taper

        p = self.p
        n = p["excited_columns"]
        if p["taper_axis"] == "columns":
            return design_taper(
                n, p["taper"], p["taylor_sll_db"], p["taylor_nbar"], p["kaiser_beta"]
            )
        # The taper over the projected aperture: positions on the chord through the sector edges.
        half = np.deg2rad(n * self.column_step_deg / 2)
        if half >= np.pi / 2:
            raise ValueError("taper_axis 'projected' needs a sector narrower than 180 deg")
        x = np.sin(np.deg2rad(self.sector_deg)) / (2 * np.sin(half))
        if p["taper"] == "taylor":
            return taylor_continuous(x, n, p["taylor_sll_db"], p["taylor_nbar"])
        if p["taper"] == "kaiser":
            # Kaiser's window is I0(beta sqrt(1 - (2x)^2)) over the aperture -1/2..1/2.
            from scipy.special import i0

            w = i0(p["kaiser_beta"] * np.sqrt(np.clip(1 - (2 * x) ** 2, 0, None)))
            return np.asarray(w / w.max())
        return np.ones(n)

    # ---- fields -------------------------------------------------------------------------------

    def broadside(self) -> tuple[float, float]:
        """The centre of the sector starting at column 0, at 0 deg elevation."""
        n = self.p["excited_columns"]
        centre = self.p["first_column_azimuth_deg"] + (n - 1) / 2 * self.column_step_deg
        return float(centre % 360.0), 0.0

    def channel_shape(self) -> tuple[int, ...]:
        return (self.p["columns"],)

    def element_layout(self) -> Any:
        """The elements' positions, normals and T/R channels (one a column) as a
        :class:`~.layouts.Layout`: what ``antenna.conformal`` reads from an element file
        (``benchmarks/make_cppar10_elements.py`` writes this one)."""
        from .layouts import ring_layout

        p = self.p
        centre = p["first_column_azimuth_deg"] + (p["columns"] - 1) / 2 * self.column_step_deg
        return ring_layout(
            p["columns"],
            self.radius_m,
            360.0,
            centre,
            p["elements_per_column"],
            p["spacing_y_m"],
        )

    def _element(self, delta_deg: np.ndarray, el_deg: np.ndarray) -> list[np.ndarray]:
        """The four field components of one element ``delta_deg`` off its normal: (el, delta)."""
        from .geometry import face_geometry

        g = face_geometry(np.asarray(delta_deg)[None, :], np.asarray(el_deg)[:, None], 0.0, 0.0)
        f = self._element_model.field(g)
        shape = (np.size(el_deg), np.size(delta_deg))
        return [np.broadcast_to(np.asarray(c, dtype=complex), shape) for c in f]

    def _column_field(self, delta_deg: np.ndarray, el_deg: np.ndarray) -> list[np.ndarray]:
        """One column's horizontal field components, ``delta_deg`` off its normal: (el, delta).

        Element field times the path phase ``k R cos(el) cos(delta)`` of a column on the
        circle (the column's vertical array factor is applied separately); in the order
        h_co, h_cross, v_co, v_cross.
        """
        phase = np.exp(
            1j
            * self.k
            * self.radius_m
            * np.cos(np.deg2rad(el_deg))[:, None]
            * np.cos(np.deg2rad(delta_deg))[None, :]
        )
        return [component * phase for component in self._element(delta_deg, el_deg)]

    def sector(self, azimuth_deg: float) -> tuple[int, float]:
        """First column of the sector that forms a beam at ``azimuth_deg``, and the beam's
        offset from that sector's centre in columns (within +-1/2)."""
        n = self.p["excited_columns"]
        first_centre = self.p["first_column_azimuth_deg"] + (n - 1) / 2 * self.column_step_deg
        rel = (azimuth_deg - first_centre) / self.column_step_deg
        nearest = int(np.round(rel))
        return nearest % self.p["columns"], float(rel - nearest)

    def column_weights(self, first: int, offset_deg: float, el_deg: float, seed: int) -> list:
        """Realised H and V weights of the sector starting at column ``first``, steering to
        ``offset_deg`` from its centre and ``el_deg`` up."""
        steer = np.deg2rad(offset_deg - self.sector_deg)
        path = self.k * self.radius_m * np.cos(np.deg2rad(el_deg)) * np.cos(steer)
        if self.channel.ideal:
            w = self.amplitude * np.exp(-1j * path)
            return [w, w]
        draw = self.draw(seed)
        if draw is not None:
            idx = (first + np.arange(self.p["excited_columns"])) % self.p["columns"]
            draw = type(draw)(draw.gain[:, idx], draw.offset[:, idx])
        return [self.channel.weights(self.amplitude, -path, draw, i) for i in (0, 1)]

    def _vertical_factor(self, sin_el: np.ndarray, steer_el_deg: float) -> np.ndarray:
        """Array factor of one column (Taylor, phase-steered), shape of ``sin_el``."""
        psi = self.k * (np.asarray(sin_el) - np.sin(np.deg2rad(steer_el_deg)))
        return np.exp(1j * np.multiply.outer(psi, self.z_m)) @ self.taper_y

    def _grid(self, first: int, step: int, el_deg: float, seed: int) -> np.ndarray:
        """Fields (4, el, az) of the beam ``step`` azimuth steps off the centre of the sector
        starting at column ``first`` (which matters only with random errors).

        The grid directions sit at ``(step + i) * az_step`` from the sector centre and the
        columns at multiples of ``per_column`` steps (plus half a column for an even sector),
        so the column sum is a correlation along azimuth, done by FFT for every row at once.
        """
        from scipy.signal import fftconvolve

        if self._memo is None:  # dropped when the block was pickled to a worker
            self._memo = {}
        # Patterns repeat from beam to beam only when the electronics draw nothing at random
        # (then they depend on the offset alone); random sectors are not kept. Once prepared,
        # the array's state is fixed, and the process's later runs of an equal array (a
        # study's seeds and reference run, a worker's next run) find its grids in SHARED.
        key = (-1, step, round(el_deg, 9))
        kept_here = not self.channel.random
        if kept_here and key in self._memo:
            return self._memo[key]
        shared = None
        if kept_here and self.prepared:
            if self._state is None:
                self._state = self._grid_state_key()
            shared = (self._state, key)
            kept = SHARED.get(shared)
            if kept is not None:
                self._memo[key] = kept
                return kept
        n, per = self.p["excited_columns"], self.per_column
        half_span = (self.d_az.size - 1) // 2
        count = self.d_az.size + (n - 1) * per
        # Column j sees grid direction i (0 .. 2 half_span) at delta = base + (i + q) * s with
        # q = (n - 1 - j) * per, so the row sum over j is a 'valid' convolution with the
        # weights spread ``per`` samples apart.
        base = (step - half_span - (n - 1) * per / 2) * self.az_step_deg
        delta = base + np.arange(count) * self.az_step_deg
        el = el_deg + self.d_el
        fields = self._column_field(delta, el)
        weights = self.column_weights(max(first, 0), step * self.az_step_deg, el_deg, seed)
        vertical = self._vertical_factor(np.sin(np.deg2rad(el)), el_deg)[:, None] / self.norm
        out = np.zeros((4, self.d_el.size, self.d_az.size), np.complex64)
        for i, f in enumerate(fields):
            if not np.any(f):
                continue  # a component the element does not radiate (e.g. the patch's H cross)
            kernel = np.zeros((1, (n - 1) * per + 1), complex)
            kernel[0, ::per] = weights[i // 2]
            out[i] = vertical * fftconvolve(f, kernel, mode="valid", axes=1)
        if kept_here:
            self._memo[key] = out if shared is None else SHARED.put(shared, out)
        return out

    def _grid_state_key(self) -> str:
        """:func:`state_key` of what the grids depend on: the whole state but the calibration
        choice (it sets the beams' radar constant, after the grids: a study's run under the
        other calibration takes the estimate's grids) and the ideal copy (made from the same
        parameters)."""
        state = self.__getstate__()
        state.pop("_ideal", None)
        state["p"] = {k: v for k, v in state["p"].items() if k != "calibration"}
        return state_key(self, state)

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        """Fields at any absolute directions by the direct sum over the sector's columns."""
        from .geometry import DualPolField

        self.prepare(resource)
        first, offset = self.sector(steer_az_deg)
        weights = self.column_weights(first, offset * self.column_step_deg, steer_el_deg, seed)
        matrix = self.column_matrix(steer_az_deg, steer_el_deg, az_deg, el_deg)
        shape = np.broadcast_shapes(np.shape(az_deg), np.shape(el_deg))
        return DualPolField(*((m @ weights[i // 2]).reshape(shape) for i, m in enumerate(matrix)))

    def column_matrix(
        self, steer_az_deg: float, steer_el_deg: float, az_deg: Any, el_deg: Any
    ) -> np.ndarray:
        """Field of every column of the beam's sector at each direction, vertical factor and
        normalisation included: (component, direction, column); times the column weights it
        gives the pattern (:meth:`fields_at`)."""
        _, offset = self.sector(steer_az_deg)
        az, el = np.broadcast_arrays(np.asarray(az_deg, float), np.asarray(el_deg, float))
        centre = steer_az_deg - offset * self.column_step_deg
        flat_az, flat_el = az.ravel(), el.ravel()
        n = self.sector_deg.size
        out = np.empty((4, flat_az.size, n), complex)
        # Directions in blocks, every column at once: (direction, column) matrices.
        block = max(1, 2**21 // n)
        for a in range(0, flat_az.size, block):
            b = min(flat_az.size, a + block)
            delta = flat_az[a:b, None] - centre - self.sector_deg[None, :]
            elevation = np.broadcast_to(flat_el[a:b, None], delta.shape)
            out[:, a:b] = self._column_field_points(delta, elevation)
        vertical = self._vertical_factor(np.sin(np.deg2rad(flat_el)), steer_el_deg) / self.norm
        out *= vertical[None, :, None]
        return out

    def _column_field_points(self, delta_deg: np.ndarray, el_deg: np.ndarray) -> list[np.ndarray]:
        """:meth:`_column_field` at paired (delta, el) points instead of on a grid."""
        from .geometry import face_geometry

        g = face_geometry(delta_deg, el_deg, 0.0, 0.0)
        f = self._element_model.field(g)
        phase = np.exp(
            1j * self.k * self.radius_m * np.cos(np.deg2rad(el_deg)) * np.cos(np.deg2rad(delta_deg))
        )
        return [np.broadcast_to(np.asarray(c), phase.shape) * phase for c in f]

    def _sphere_integral(self) -> np.ndarray:
        """Integral of the reference beam's one-way H and V power over the sphere (sr).

        ``int dv int d(az) |A(v)|^2 |S(az, v)|^2`` with ``v = sin(el)``: the horizontal sum
        ``S`` (co- and cross-polar components) round the whole circle is a circular
        convolution (exact trapezoid rule for a periodic band-limited integrand), its azimuth
        integral ``I(v)`` is smooth and is splined from a coarse ``v`` grid onto the fine grid
        of the vertical factor ``A(v)``.
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
        weights = self.column_weights(0, 0.0, 0.0, 0)
        profile = np.zeros((2, v.size))
        for i, f in enumerate(self._column_field(delta, el)):
            if not np.any(f):
                continue
            kernel = np.zeros(size, complex)
            kernel[np.arange(n) * per] = weights[i // 2]
            s = np.fft.ifft(np.fft.fft(f, axis=1) * np.fft.fft(kernel), axis=1) / self.norm
            profile[i // 2] += np.sum(s.real**2 + s.imag**2, axis=1) * np.deg2rad(step_deg)
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
        return int(np.round(self.sector(azimuth_deg)[1] * self.per_column))

    def beam_fields(
        self, az_deg: float, el_deg: float, seed: int, resource: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        self.prepare(resource)
        first, _ = self.sector(az_deg)
        f = self._grid(first, self.beam_offset_steps(az_deg), el_deg, seed)
        return f[0], f[2], f[1], f[3]

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams"]
        co, cross = self.beam_grids(*steering(beams), chunk.seed, chunk.resource)
        ds = self.pattern_output(
            beams,
            co,
            cross,
            antenna="cylindrical",
            directivity_h_db=self.directivity_db["H"],
            directivity_v_db=self.directivity_db["V"],
        )
        return {"pattern": ds}
