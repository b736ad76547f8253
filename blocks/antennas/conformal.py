"""Arrays of any geometry: one computation for every set of element positions and normals.

:class:`ConformalArray` sums the field of every element of a :class:`~.layouts.Layout` on its
own position, each element's pattern turned to its own outward normal (as the cylinder does),
with the channel electronics of :mod:`.electronics` acting on the layout's T/R channels. The
geometry blocks (:mod:`.shaped`: ``antenna.linear``, ``antenna.ring``, ``antenna.lattice``) and
``antenna.conformal`` (a file of element positions and normals, :class:`ElementFileArray`)
differ only in the layout they give.

A beam steered to ``r0`` is formed by the *active* columns: those whose normal's azimuth lies
within ``active_sector_deg / 2`` of the beam's azimuth (half-open, ``[-S/2, S/2)``: a
commutated sector as on the cylinder; every column when the array has no sector). Weights:
the taper across the active columns (``taper_axis``: ``columns``, the design taper sampled per
column in the order of their positions across the beam, or ``projected``, the continuous
taper at those positions) times the taper up the stack, phase ``-k p . r0`` at every element.
Each T/R channel realises the sum of its elements' amplitudes and the phase of its elements'
centre (attenuator, phase shifter, errors, failure); behind it the elements keep their share of
the amplitude and either stay in phase (``subarray_feed: in_phase``, a passive divider, the
planar array's subarrays) or are steered ideally about the channel's centre (``steered``, the
cylinder's column feed). Patterns are normalised to the ideal array's H co-polar peak steered
to broadside, ``gain_db`` is that beam's directivity from the full-sphere integral.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Param

from ..signals import POLARIZATIONS
from .array import ArrayAntenna, ideal_copy
from .base import KAISER_BETA, PATTERN_SUPPORT, TAPER, offsets, two_way_solid_angle
from .geometry import DualPolField
from .layouts import Layout

#: Directions evaluated at once: bounds the (columns x directions) temporaries to ~32 MB.
_BLOCK = 2**20
#: Beam and column azimuths this close (deg) to the edge of a sector count as on it.
_EDGE_DEG = 1e-9


class ConformalArray(ArrayAntenna):
    """Base of the arrays computed from element positions and normals (module docstring);
    a subclass gives :meth:`build_layout` and :meth:`broadside`."""

    @classmethod
    def warm_up(cls) -> None:
        super().warm_up()
        # Each beam's taper is drawn from scipy.signal's windows: it (and the 420 modules it
        # pulls in) was imported by a worker's first chunk (0.55 s of CPU).
        import scipy.signal  # noqa: F401

        from . import cylindrical  # noqa: F401  (its continuous Taylor taper)

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    element = Param(
        "patch",
        type="str",
        choices=("patch", "crossed_dipole", "isotropic", "omni", "file"),
        doc="radiating element: cavity-model patch, crossed dipoles, isotropic (front half-space), "
        "omni (unit field all round, no ground plane), or element_file",
    )
    taper = TAPER
    taylor_sll_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor sidelobe level across the columns"
    )
    taylor_nbar = Param(5, type="int", min=1, max=50, doc="Taylor nbar across the columns")
    taylor_sll_y_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor sidelobe level up the stack"
    )
    taylor_nbar_y = Param(5, type="int", min=1, max=50, doc="Taylor nbar up the stack")
    kaiser_beta = KAISER_BETA
    taper_axis = Param(
        "columns",
        type="str",
        choices=("columns", "projected"),
        doc="across taper sampled per active column, or at their positions projected across "
        "the beam",
    )
    subarray_feed = Param(
        "in_phase",
        type="str",
        choices=("in_phase", "steered"),
        doc="elements behind one T/R channel: in phase (passive divider) or steered ideally "
        "about the channel's centre (a column feed)",
    )
    support_deg = PATTERN_SUPPORT
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    transient = ("_draws",)
    layout: Layout

    # ---- what a geometry gives ------------------------------------------------------------

    def build_layout(self, resource: Any) -> Layout:
        """The element positions, normals and channels (``resource``: what :meth:`load` read)."""
        raise NotImplementedError

    def beam_sector_deg(self) -> float:
        """Azimuth span of the columns that form a beam (360: every column)."""
        return 360.0

    def element_table(self, resource: Any) -> Any:
        """The element pattern table among what :meth:`load` read."""
        return resource

    # ---- set-up ----------------------------------------------------------------------------

    def setup(self) -> None:
        from ..signals import SPEED_OF_LIGHT

        super().setup()
        p = self.p
        self.k = 2 * np.pi * p["frequency_hz"] / SPEED_OF_LIGHT
        self.d_az = offsets(p["support_deg"], p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self.omega: dict[str, float] = {}
        self.prepared = False
        if not self.needs_resource():
            self.prepare(None)

    def needs_resource(self) -> bool:
        return bool(self.p["element"] == "file")

    def make_element(self, resource: Any) -> Any:
        from .elements import make_element

        if self.p["element"] == "omni":
            return _Omni() if self.p["cross_pol_db"] is None else _leaky(_Omni(), self.p)
        return make_element(
            self.p["element"],
            patch_m=self.p["patch_m"],
            frequency_hz=self.p["frequency_hz"],
            cross_pol_db=self.p["cross_pol_db"],
            cross_pol_phase_deg=self.p["cross_pol_phase_deg"],
            table=self.element_table(resource),
        )

    def prepare(self, resource: Any) -> None:
        """Layout, element, stack taper and the normalisation (the ideal broadside peak)."""
        from .tapers import design_taper

        if self.prepared:
            return
        p = self.p
        self.layout = self.build_layout(resource)
        tilt = self.layout.normal_tilt_deg
        if p["element"] == "file" and np.any(np.abs(tilt) > 1e-6):
            raise ValueError(
                f"antenna {self.name!r}: a tabulated element (element 'file') needs horizontal "
                f"normals; this array has normals tilted up to {np.abs(tilt).max():.3g} deg"
            )
        self.element_model = self.make_element(resource)
        # The phase a channel commands is that of its elements' centre (all its elements).
        n, members = self.layout.n_channels, self.layout.channel.ravel()
        positions = self.layout.positions().reshape(-1, 3)
        count = np.maximum(np.bincount(members, minlength=n), 1)
        self.channel_centre = np.stack(
            [np.bincount(members, positions[:, i], minlength=n) / count for i in range(3)], axis=1
        )
        m = self.layout.stack_m.size
        self.taper_stack = (
            np.ones(1)
            if m == 1
            else design_taper(
                m, p["taper"], p["taylor_sll_y_db"], p["taylor_nbar_y"], p["kaiser_beta"]
            )
        )
        az0, el0 = self.broadside()
        w, _, act = self._ideal_weights(az0, el0)
        f = self._evaluate(act, w, w, np.array([az0]), np.array([el0]), norm=1.0)
        norm = float(np.abs(f.h_co[0]))
        if not norm > 0:
            raise ValueError(f"antenna {self.name!r}: no field at broadside ({az0:g}, {el0:g})")
        self.norm = norm  # set once: other threads may already be evaluating
        self.prepared = True

    # ---- weights ---------------------------------------------------------------------------

    def channel_shape(self) -> tuple[int, ...]:
        return (self.layout.n_channels,)

    def active(self, steer_az_deg: float) -> np.ndarray:
        """Indices of the columns that form a beam at ``steer_az_deg``."""
        sector = self.beam_sector_deg()
        if sector >= 360.0:
            return np.arange(self.layout.normal.shape[0])
        delta = (self.layout.normal_azimuth_deg - steer_az_deg + 180.0) % 360.0 - 180.0
        inside = (delta >= -sector / 2 - _EDGE_DEG) & (delta < sector / 2 - _EDGE_DEG)
        return np.flatnonzero(inside)

    def across_taper(self, columns: np.ndarray, steer_az_deg: float) -> np.ndarray:
        """The taper across the active ``columns``, from their positions across the beam."""
        from .cylindrical import taylor_continuous
        from .tapers import design_taper

        p = self.p
        a = np.deg2rad(steer_az_deg)
        across = self.layout.column_position[columns] @ np.array([np.cos(a), -np.sin(a), 0.0])
        distinct, rank = np.unique(np.round(across / 1e-6), return_inverse=True)
        n = distinct.size
        if n == 1 or p["taper"] == "uniform":
            return np.ones(columns.size)
        if p["taper_axis"] == "columns":
            taper = design_taper(
                n, p["taper"], p["taylor_sll_db"], p["taylor_nbar"], p["kaiser_beta"]
            )
            return np.asarray(taper[rank.ravel()])
        lo, hi = across.min(), across.max()
        # -1/2 .. 1/2 over the aperture, whose edges are half a column spacing (of the
        # projected positions, on average) beyond the outer columns: on a uniform line, the
        # design taper's own samples.
        x = (across - (lo + hi) / 2) / (hi - lo) * (n - 1) / n
        if p["taper"] == "taylor":
            return taylor_continuous(x, n, p["taylor_sll_db"], p["taylor_nbar"])
        from scipy.special import i0

        w = i0(p["kaiser_beta"] * np.sqrt(np.clip(1 - (2 * x) ** 2, 0, None)))
        return np.asarray(w / w.max())

    def up_taper(self, columns: np.ndarray) -> np.ndarray:
        """The taper up the active ``columns`` by the rank of their heights, for a layout
        without a stack (one element a column: a file of single elements); 1 with a stack,
        which is tapered along itself."""
        from .tapers import design_taper

        p = self.p
        if self.layout.stack_m.size > 1 or p["taper"] == "uniform":
            return np.ones(columns.size)
        height = self.layout.column_position[columns, 2]
        distinct, rank = np.unique(np.round(height / 1e-6), return_inverse=True)
        if distinct.size == 1:
            return np.ones(columns.size)
        taper = design_taper(
            distinct.size, p["taper"], p["taylor_sll_y_db"], p["taylor_nbar_y"], p["kaiser_beta"]
        )
        return np.asarray(taper[rank.ravel()])

    def _ideal_weights(
        self, steer_az_deg: float, steer_el_deg: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Commanded amplitudes (columns x stack, active columns only), phases and the active
        columns of a beam."""
        act = self.active(steer_az_deg)
        if act.size == 0:
            raise ValueError(
                f"antenna {self.name!r}: no element faces azimuth {steer_az_deg:g} deg within "
                f"the active sector ({self.beam_sector_deg():g} deg)"
            )
        amplitude = np.outer(
            self.across_taper(act, steer_az_deg) * self.up_taper(act), self.taper_stack
        )
        r0 = _direction(np.array([steer_az_deg]), np.array([steer_el_deg]))[0]
        phase = -self.k * (self.layout.positions()[act] @ r0)
        return amplitude * np.exp(1j * phase), phase, act

    def weights(
        self, steer_az_deg: float, steer_el_deg: float, seed: int = 0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Realised H and V weights (active columns x stack) and the active columns."""
        ideal, phase, act = self._ideal_weights(steer_az_deg, steer_el_deg)
        layout, p = self.layout, self.p
        channel = layout.channel[act]
        if self.channel.ideal and p["subarray_feed"] == "steered":
            return ideal, ideal, act  # every element at its own commanded weight
        amplitude = np.abs(ideal)
        total = np.bincount(channel.ravel(), amplitude.ravel(), minlength=layout.n_channels)
        r0 = _direction(np.array([steer_az_deg]), np.array([steer_el_deg]))[0]
        commanded = -self.k * (self.channel_centre @ r0)
        share = np.divide(
            amplitude, total[channel], out=np.zeros_like(amplitude), where=total[channel] > 0
        )
        if p["subarray_feed"] == "steered":
            share = share * np.exp(1j * (phase - commanded[channel]))
        draw = self.draw(seed)
        out = [share * self.channel.weights(total, commanded, draw, i)[channel] for i in (0, 1)]
        return out[0], out[1], act

    # ---- fields ----------------------------------------------------------------------------

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> DualPolField:
        self.prepare(resource)
        w_h, w_v, act = self.weights(steer_az_deg, steer_el_deg, seed)
        az, el = np.broadcast_arrays(np.asarray(az_deg, float), np.asarray(el_deg, float))
        f = self._evaluate(act, w_h, w_v, az.ravel(), el.ravel())
        return DualPolField(*(c.reshape(az.shape) for c in f))

    def _evaluate(
        self,
        act: np.ndarray,
        w_h: np.ndarray,
        w_v: np.ndarray,
        az: np.ndarray,
        el: np.ndarray,
        stack: bool = True,
        norm: float | None = None,
    ) -> DualPolField:
        """Fields at the flat directions (``az``, ``el``) of the ``act`` columns weighted
        ``w_h``, ``w_v`` (columns x stack; with ``stack`` False, one weight a column and no
        stack factor), divided by ``norm`` (default: the normalisation)."""
        layout = self.layout
        position = layout.column_position[act]
        normal_az = layout.normal_azimuth_deg[act]
        tilt = np.round(layout.normal_tilt_deg[act], 9)
        out = np.zeros((4, az.size), complex)
        block = max(1, _BLOCK // max(act.size, layout.stack_m.size))
        for a in range(0, az.size, block):
            b = min(az.size, a + block)
            r = _direction(az[a:b], el[a:b])
            phase = np.exp(1j * self.k * (position @ r.T))  # columns x directions
            if stack:
                g = np.exp(1j * self.k * np.outer(layout.stack_m, r @ layout.axis))
                b_h = (w_h @ g) * phase
                b_v = b_h if w_v is w_h else (w_v @ g) * phase
            else:
                b_h = w_h[:, None] * phase
                b_v = b_h if w_v is w_h else w_v[:, None] * phase
            for t in np.unique(tilt):
                rows = np.flatnonzero(tilt == t)
                e = self._element_fields(normal_az[rows], float(t), az[a:b], el[a:b])
                for i, component in enumerate(e):
                    if np.any(component):
                        weight = (b_h if i < 2 else b_v)[rows]
                        out[i, a:b] += np.sum(component * weight, axis=0)
        return DualPolField(*(out / (self.norm if norm is None else norm)))

    def _element_fields(
        self, normal_az: np.ndarray, tilt_deg: float, az: np.ndarray, el: np.ndarray
    ) -> list[np.ndarray]:
        """The element's four field components, (columns, directions), each column's pattern
        turned to its own normal."""
        from .geometry import face_geometry

        g = face_geometry(az[None, :], el[None, :], normal_az[:, None], tilt_deg)  # type: ignore[arg-type]
        shape = (normal_az.size, az.size)
        return [np.broadcast_to(np.asarray(c), shape) for c in self.element_model.field(g)]

    # ---- broadside figures -----------------------------------------------------------------

    def broadside_figures(self, resource: Any = None) -> None:
        """Two-way solid angles of the broadside beam and the directivity (``gain_db``)."""
        self.prepare(resource)
        if self.omega:
            return
        ideal = ideal_copy(self)
        if ideal is not self:
            ideal.prepare(resource)
            ideal.broadside_figures(resource)
            self.gain_db = ideal.gain_db
            self.omega = ideal.omega  # last: a filled omega says the figures are there
            return
        az0, el0 = self.broadside()
        co, _ = self.beam_grid(az0, el0, 0, resource)
        power = co.real**2 + co.imag**2
        self.gain_db = float(10 * np.log10(4 * np.pi / self._sphere_integral()))
        self.omega = {
            pol: two_way_solid_angle(power[i], self.d_az, self.d_el, el0)
            for i, pol in enumerate(POLARIZATIONS)
        }

    def _sphere_integral(self) -> float:
        """Integral of the ideal broadside beam's one-way H power (co + cross) over the sphere.

        Coordinates about the stack axis ``a``: ``t = a . r`` and the angle ``phi`` round it,
        ``d Omega = d phi dt``. The stack factor ``|V(t)|^2`` is common to every column; the
        columns' sum is integrated over ``phi`` (periodic trapezoid, exact for its band limit
        ``2 k R``) on a grid of ``psi = asin t`` where it is smooth, splined onto the fine
        ``t`` grid of ``V``.
        """
        from scipy.interpolate import CubicSpline

        layout = self.layout
        az0, el0 = self.broadside()
        ideal, _, act = self._ideal_weights(az0, el0)
        columns = ideal[:, 0] / self.taper_stack[0]
        stack_w = ideal[0] / ideal[0, 0] * self.taper_stack[0]
        a = layout.axis
        position = layout.column_position[act] - layout.column_position[act].mean(axis=0)
        along = position @ a
        radial = np.linalg.norm(position - np.outer(along, a), axis=1).max()
        extent = np.ptp(along) + np.ptp(layout.stack_m)
        n_phi = int(2 * self.k * radial) + 64
        n_psi = int(4 * self.k * np.ptp(along) + self.k * radial / 16) + 33
        e1 = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        phi = np.arange(n_phi) * 2 * np.pi / n_phi
        psi = np.linspace(-np.pi / 2, np.pi / 2, n_psi)
        ring = np.cos(phi)[None, :, None] * e1 + np.sin(phi)[None, :, None] * e2
        r = np.cos(psi)[:, None, None] * ring + np.sin(psi)[:, None, None] * a
        r = r.reshape(-1, 3)
        az = np.rad2deg(np.arctan2(r[:, 0], r[:, 1]))
        el = np.rad2deg(np.arcsin(np.clip(r[:, 2], -1, 1)))
        f = self._evaluate(act, columns, columns, az, el, stack=False)
        power = (np.abs(f.h_co) ** 2 + np.abs(f.h_cross) ** 2).reshape(n_psi, n_phi)
        profile = power.sum(axis=1) * (2 * np.pi / n_phi)
        t = np.linspace(-1.0, 1.0, int(8 * self.k * extent) + 4001)
        vertical = np.abs(np.exp(1j * self.k * np.outer(t, layout.stack_m)) @ stack_w) ** 2
        smooth = CubicSpline(psi, profile)(np.arcsin(t))
        return float(np.trapezoid(vertical * smooth, t))

    def pattern_gain_db(self, resource: Any = None) -> float:
        self.broadside_figures(resource)
        return float(self.gain_db)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams"]
        self.broadside_figures(chunk.resource)
        co, cross = self.beam_grids(
            beams["azimuth"].values, beams["elevation"].values, chunk.seed, chunk.resource
        )
        label = self.type_name or type(self).__name__
        return {"pattern": self.pattern_output(beams, co, cross, antenna=label)}


def _direction(az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    """East-north-up unit vectors (n, 3) of azimuths (clockwise from north) and elevations."""
    az, el = np.deg2rad(az_deg), np.deg2rad(el_deg)
    return np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=-1)


class _Omni:
    """Unit H and V fields in every direction (no ground plane): the isotropic radiator of
    the textbook array formulas (a ring's Bessel pattern)."""

    def field(self, g: Any) -> DualPolField:
        one = np.ones(np.shape(g.w))
        zero = np.zeros_like(one)
        return DualPolField(h_co=one, h_cross=zero, v_co=one, v_cross=zero)


def _leaky(base: Any, p: dict[str, Any]) -> Any:
    from .elements import LeakyElement

    leak = 10 ** (p["cross_pol_db"] / 20) * np.exp(1j * np.deg2rad(p["cross_pol_phase_deg"]))
    return LeakyElement(base, complex(leak))
