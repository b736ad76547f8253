"""Antenna radiation patterns: an analytic pencil beam and a steered planar array of patches.

Two models live here, both as pure functions of direction:

* :class:`PencilBeam` — the "generic radar" of the PASIM paper (Table 4): a circular
  aperture with the illumination taper ``g(rho) = (1 - rho**2)**p``, whose
  exponent ``p`` is solved for the requested first sidelobe and whose diameter is solved for
  the requested 3-dB beamwidth. Its field pattern has the closed form
  ``E(u) = Gamma(nu + 1) (2/u)**nu J_nu(u)`` with ``nu = p + 1`` and ``u = pi D sin(theta)/lambda``.
* :func:`planar_array_power` — a uniform rectangular array of dual-polarised square patches
  (paper section 2.2.1) with a separable Taylor taper (section 2.2.2), steered by ideal
  phase shifters. The complex element weights are an explicit intermediate
  (:func:`planar_array_weights`) so that phase-shifter quantisation, channel-to-channel errors
  and failed elements can be applied to them before :func:`array_factor` is evaluated.

Angles at the public interface are in degrees; azimuth is clockwise from north and elevation
is above the horizon. The global frame is east-north-up.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray
from scipy import optimize, signal, special

__all__ = [
    "SPEED_OF_LIGHT",
    "DualPolField",
    "FaceGeometry",
    "PencilBeam",
    "SeparableWeights",
    "array_factor",
    "array_fields",
    "circular_aperture_pattern",
    "design_taper",
    "element_positions",
    "face_direction_cosines",
    "face_geometry",
    "first_sidelobe_db",
    "half_power_beamwidth_deg",
    "main_lobe_bounds",
    "patch_element_field",
    "patch_field",
    "peak_sidelobe_db",
    "pencil_beam_power",
    "planar_array_directivity_db",
    "planar_array_fields",
    "planar_array_power",
    "planar_array_weights",
    "taper_efficiency",
    "taylor_taper",
]

SPEED_OF_LIGHT = 299_792_458.0  # m/s

# Largest taper exponent the designer will use. p = 20 already gives a first sidelobe near
# -103 dB, far beyond any real reflector, so the limit only guards the root finder.
_MAX_TAPER_EXPONENT = 20.0
# Step of the pencil-beam lookup table in u. With cubic Hermite interpolation and exact slopes
# the amplitude error is below step**4 / 384 * max|E''''| ~ 3e-10 (E'''' <= 1/8 at u = 0).
_PENCIL_TABLE_STEP = 1.0 / 32.0
# Oversampling of the array-factor lookup table relative to the number of elements. The table
# holds a trigonometric polynomial of frequencies up to n/2; with 128 samples per element and
# cubic Hermite interpolation the error is ~(pi/128)^4/384 ~ 1e-9 of the array's coherent sum.
_AF_OVERSAMPLING = 128
# Points per block in the exact (non-separable) array-factor path: bounds the temporary
# (points x elements) matrices to a few megabytes so they stay cache friendly.
_AF_CHUNK = 2048


# --------------------------------------------------------------------------------------------
# Shared numerical helpers
# --------------------------------------------------------------------------------------------


def _hermite_table(values: NDArray, slopes: NDArray) -> NDArray:
    """Cubic Hermite polynomial coefficients for each interval of a unit-spaced table.

    Parameters
    ----------
    values, slopes : ndarray
        Samples of a function on the grid 0, 1, ..., n - 1 and of its derivative with respect
        to the grid index.

    Returns
    -------
    ndarray
        Shape ``(4, n - 1)``: on interval ``i`` the function is
        ``c[0, i] + t (c[1, i] + t (c[2, i] + t c[3, i]))`` with ``t`` in [0, 1].
    """
    v0, v1, s0, s1 = values[:-1], values[1:], slopes[:-1], slopes[1:]
    # Storing the monomial coefficients once makes each lookup four gathers and a Horner step.
    return np.stack([v0, s0, 3.0 * (v1 - v0) - 2.0 * s0 - s1, 2.0 * (v0 - v1) + s0 + s1])


def _hermite_eval(table: NDArray, x: NDArray) -> NDArray:
    """Evaluate a :func:`_hermite_table` at fractional grid positions ``x`` in [0, n - 1]."""
    i = np.minimum(x.astype(np.intp), table.shape[1] - 1)
    t = x - i
    c0, c1, c2, c3 = table
    out = c3[i]
    out *= t
    out += c2[i]
    out *= t
    out += c1[i]
    out *= t
    out += c0[i]
    return out


# --------------------------------------------------------------------------------------------
# Pencil beam: tapered circular aperture
# --------------------------------------------------------------------------------------------


def circular_aperture_pattern(u: npt.ArrayLike, taper_exponent: float) -> NDArray[np.float64]:
    """Normalised far-field amplitude of a circular aperture with taper ``(1 - rho^2)^p``.

    Evaluates ``E(u) = int_0^1 g(rho) J0(u rho) rho drho / int_0^1 g(rho) rho drho`` through
    its closed form ``Gamma(nu + 1) (2/u)^nu J_nu(u)`` with ``nu = p + 1`` (Sonine's integral).

    Parameters
    ----------
    u : array_like
        Pattern variable ``pi D sin(theta) / lambda``; the pattern is even in ``u``.
    taper_exponent : float
        Exponent ``p >= 0`` of the illumination taper (0 is uniform illumination).

    Returns
    -------
    ndarray
        Real amplitude, 1 at ``u = 0``, same shape as ``u``.
    """
    if taper_exponent < 0:
        raise ValueError(f"taper_exponent must be >= 0, got {taper_exponent}")
    nu = taper_exponent + 1.0
    x = np.abs(np.asarray(u, dtype=float))
    out = np.empty_like(x)
    # (2/u)^nu J_nu(u) is 0 * inf at u -> 0; the power series to u^4 is exact to 1e-18 there.
    small = x < 1e-3
    us2 = x[small] ** 2
    out[small] = 1.0 - us2 / (4.0 * (nu + 1.0)) + us2**2 / (32.0 * (nu + 1.0) * (nu + 2.0))
    ul = x[~small]
    out[~small] = np.exp(special.gammaln(nu + 1.0) + nu * np.log(2.0 / ul)) * special.jv(nu, ul)
    return out


def _first_bessel_zero(order: float) -> float:
    """First positive zero of J_order for real order >= 0 (scipy only tabulates integer orders)."""
    # j_{nu,1} lies in (nu, nu + 20) for every order the designer can reach (nu <= 23).
    x = order + 0.05 * np.arange(1, 401)
    negative = np.flatnonzero(special.jv(order, x) < 0)
    if negative.size == 0:
        raise ValueError(f"no zero of J_{order} found below {x[-1]:.1f}")
    i = negative[0]
    return float(optimize.brentq(lambda t: special.jv(order, t), x[i - 1], x[i], xtol=1e-14))


def _aperture_sidelobe_db(taper_exponent: float) -> float:
    """First sidelobe level (power, dB below the peak) of the tapered circular aperture."""
    # dE/du is proportional to -Lambda_{nu+1}(u), so the first sidelobe peak sits exactly at the
    # first zero of J_{nu+1}: no search over the pattern is needed.
    u_peak = _first_bessel_zero(taper_exponent + 2.0)
    return float(20.0 * np.log10(abs(circular_aperture_pattern(u_peak, taper_exponent))))


def _aperture_half_power_u(taper_exponent: float) -> float:
    """Pattern variable u at which the one-way power pattern is 0.5 (inside the main lobe)."""
    u_null = _first_bessel_zero(taper_exponent + 1.0)
    return float(
        optimize.brentq(
            lambda u: circular_aperture_pattern(u, taper_exponent) ** 2 - 0.5,
            1e-6,
            u_null,
            xtol=1e-14,
        )
    )


@dataclass(frozen=True)
class PencilBeam:
    """Axially symmetric pencil beam of a tapered circular aperture.

    Build it with :meth:`design` (from beamwidth and sidelobe, as in the paper's Table 4) or
    :meth:`from_taper` (from the aperture itself). The pattern is tabulated once in ``u`` at
    construction, so :meth:`power` is a table lookup.

    Attributes
    ----------
    taper_exponent : float
        Exponent ``p`` of the illumination ``(1 - rho^2)^p``.
    diameter_wavelengths : float
        Aperture diameter ``D / lambda``.
    """

    taper_exponent: float
    diameter_wavelengths: float
    _table: NDArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.taper_exponent >= 0:
            raise ValueError(f"taper_exponent must be >= 0, got {self.taper_exponent}")
        if not self.diameter_wavelengths > 0:
            raise ValueError(f"diameter_wavelengths must be > 0, got {self.diameter_wavelengths}")
        # The table covers 0..90 deg off axis: u_max = pi D / lambda.
        u_max = np.pi * self.diameter_wavelengths
        n = int(np.ceil(u_max / _PENCIL_TABLE_STEP)) + 2
        u = _PENCIL_TABLE_STEP * np.arange(n)
        values = circular_aperture_pattern(u, self.taper_exponent)
        # d/du Lambda_nu(u) = -u / (2 (nu + 1)) Lambda_{nu+1}(u): exact slopes for the Hermite
        # table, scaled to "per table step".
        nu = self.taper_exponent + 1.0
        slopes = (
            -u / (2.0 * (nu + 1.0)) * circular_aperture_pattern(u, self.taper_exponent + 1.0)
        ) * _PENCIL_TABLE_STEP
        object.__setattr__(self, "_table", _hermite_table(values, slopes))

    @classmethod
    def from_taper(cls, taper_exponent: float, diameter_wavelengths: float) -> PencilBeam:
        """Pencil beam of a given aperture.

        Parameters
        ----------
        taper_exponent : float
            Exponent ``p >= 0`` of the illumination ``(1 - rho^2)^p``.
        diameter_wavelengths : float
            Aperture diameter in wavelengths.

        Returns
        -------
        PencilBeam
        """
        return cls(float(taper_exponent), float(diameter_wavelengths))

    @classmethod
    def design(cls, beamwidth_deg: float, first_sidelobe_db: float) -> PencilBeam:
        """Aperture whose pattern has the requested 3-dB beamwidth and first sidelobe.

        The taper exponent is found by root finding on the exact first sidelobe level, then the
        diameter is scaled so that the one-way half-power full width equals ``beamwidth_deg``.

        Parameters
        ----------
        beamwidth_deg : float
            One-way 3-dB full beamwidth, degrees, in (0, 90).
        first_sidelobe_db : float
            First sidelobe level, power in dB relative to the peak (negative). Reachable range:
            from -17.57 dB (uniform illumination, the highest a non-negative taper of this family
            gives) down to the level of ``p = 20`` (about -103 dB).

        Returns
        -------
        PencilBeam

        Raises
        ------
        ValueError
            If the beamwidth is outside (0, 90) degrees or the sidelobe level is not reachable.
        """
        if not 0.0 < beamwidth_deg < 90.0:
            raise ValueError(f"beamwidth_deg must be in (0, 90), got {beamwidth_deg}")
        highest = _aperture_sidelobe_db(0.0)
        lowest = _aperture_sidelobe_db(_MAX_TAPER_EXPONENT)
        if not lowest <= first_sidelobe_db <= highest:
            raise ValueError(
                f"first_sidelobe_db={first_sidelobe_db} dB is not reachable with a (1 - rho^2)^p "
                f"taper: the range is {lowest:.1f} dB (p={_MAX_TAPER_EXPONENT:g}) to "
                f"{highest:.2f} dB (uniform illumination)"
            )
        if first_sidelobe_db == highest:
            p = 0.0
        else:
            p = float(
                optimize.brentq(
                    lambda q: _aperture_sidelobe_db(q) - first_sidelobe_db,
                    0.0,
                    _MAX_TAPER_EXPONENT,
                    xtol=1e-12,
                )
            )
        u_half = _aperture_half_power_u(p)
        diameter = u_half / (np.pi * np.sin(np.radians(beamwidth_deg) / 2.0))
        return cls(p, float(diameter))

    @property
    def beamwidth_deg(self) -> float:
        """One-way 3-dB full beamwidth, degrees (exact, from the half-power root)."""
        u_half = _aperture_half_power_u(self.taper_exponent)
        return float(2.0 * np.degrees(np.arcsin(u_half / (np.pi * self.diameter_wavelengths))))

    @property
    def first_sidelobe_db(self) -> float:
        """First sidelobe level, power in dB relative to the peak (exact)."""
        return _aperture_sidelobe_db(self.taper_exponent)

    @property
    def taper_efficiency(self) -> float:
        """Aperture (taper) efficiency ``(2p + 1) / (p + 1)^2`` of the illumination."""
        p = self.taper_exponent
        return (2.0 * p + 1.0) / (p + 1.0) ** 2

    @property
    def directivity_db(self) -> float:
        """Directivity ``(pi D / lambda)^2 * taper efficiency`` in dBi (no spillover or losses)."""
        return float(
            10.0 * np.log10((np.pi * self.diameter_wavelengths) ** 2 * self.taper_efficiency)
        )

    def amplitude(self, theta_deg: npt.ArrayLike) -> NDArray[np.float64]:
        """One-way field amplitude (real, signed, 1 on axis) at angle ``theta_deg`` off axis.

        Parameters
        ----------
        theta_deg : array_like
            Angle between the direction and the beam axis, degrees, any shape.
            Angles beyond 90 degrees (behind the aperture plane) take the value at 90 degrees:
            the aperture model has no back lobe, and the pattern there is already negligible
            (about -148 dB for the 1-degree, -32 dB generic beam).

        Returns
        -------
        ndarray
            Same shape as ``theta_deg``.
        """
        theta = np.minimum(np.abs(np.radians(np.asarray(theta_deg, dtype=float))), np.pi / 2)
        u = np.pi * self.diameter_wavelengths * np.sin(theta)
        return _hermite_eval(self._table, u / _PENCIL_TABLE_STEP)

    def power(self, theta_deg: npt.ArrayLike) -> NDArray[np.float64]:
        """One-way normalised power pattern ``|E|^2`` (1 on axis).

        Parameters
        ----------
        theta_deg : array_like
            Angle off the beam axis, degrees, any shape; beyond 90 degrees the value at
            90 degrees is returned (see :meth:`amplitude`).

        Returns
        -------
        ndarray
            Same shape as ``theta_deg``.
        """
        return self.amplitude(theta_deg) ** 2


def pencil_beam_power(
    d_az_deg: npt.ArrayLike,
    d_el_deg: npt.ArrayLike,
    beam: PencilBeam,
    *,
    el0_deg: float = 0.5,
) -> NDArray[np.float64]:
    """One-way power of a pencil beam on a grid of azimuth/elevation offsets from its axis.

    The angle off axis is the true great-circle angle between the direction
    ``(az0 + d_az, el0 + d_el)`` and the axis ``(az0, el0)``, so beams at high elevation are
    correctly narrower in azimuth offset; for small offsets it is close to
    ``sqrt((d_az cos el0)^2 + d_el^2)``.

    Parameters
    ----------
    d_az_deg, d_el_deg : array_like
        Azimuth and elevation offsets from the beam axis, degrees; broadcast together.
    beam : PencilBeam
        The beam.
    el0_deg : float, optional
        Elevation of the beam axis, degrees (default 0.5).

    Returns
    -------
    ndarray
        Power pattern (1 on axis), shape of the broadcast offsets.
    """
    d_az = np.radians(np.asarray(d_az_deg, dtype=float))
    d_el = np.radians(np.asarray(d_el_deg, dtype=float))
    el0 = np.radians(el0_deg)
    # Haversine form: the arccos of a dot product loses all precision for sub-degree offsets.
    hav = np.sin(d_el / 2.0) ** 2 + np.cos(el0) * np.cos(el0 + d_el) * np.sin(d_az / 2.0) ** 2
    off_axis = 2.0 * np.arcsin(np.sqrt(np.clip(hav, 0.0, 1.0)))
    return beam.power(np.degrees(off_axis))


# --------------------------------------------------------------------------------------------
# Planar array geometry and the dual-polarised patch element
# --------------------------------------------------------------------------------------------


class FaceGeometry(NamedTuple):
    """Directions in a face frame, plus the face axes projected on the local (h, v) basis."""

    u: NDArray
    v: NDArray
    w: NDArray
    x_dot_h: NDArray
    x_dot_v: NDArray
    y_dot_h: NDArray
    y_dot_v: NDArray


def face_geometry(
    az_deg: npt.ArrayLike, el_deg: npt.ArrayLike, face_azimuth_deg: float, face_tilt_deg: float
) -> FaceGeometry:
    """Everything the element and array models need from the directions, trig done once."""
    d_az = np.radians(np.asarray(az_deg, dtype=float) - face_azimuth_deg)
    el = np.radians(np.asarray(el_deg, dtype=float))
    tilt = np.radians(face_tilt_deg)
    cos_d, sin_d = np.cos(d_az), np.sin(d_az)
    cos_el, sin_el = np.cos(el), np.sin(el)
    cos_t, sin_t = np.cos(tilt), np.sin(tilt)
    horizontal_normal = cos_el * cos_d  # component along the untilted normal
    # Untilted faces keep v a function of elevation only (and its shape), which the separable
    # array factor exploits.
    v = sin_el if tilt == 0.0 else cos_t * sin_el - sin_t * horizontal_normal
    # The face x axis is horizontal whatever the tilt; y = x cross normal is "up the face".
    return FaceGeometry(
        u=cos_el * sin_d,
        v=v,
        w=sin_t * sin_el + cos_t * horizontal_normal,
        x_dot_h=cos_d,
        x_dot_v=-sin_el * sin_d,
        y_dot_h=sin_t * sin_d,
        y_dot_v=cos_t * cos_el + sin_t * sin_el * cos_d,
    )


def face_direction_cosines(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Direction cosines of absolute directions in the frame of an array face.

    The face frame has ``x`` horizontal along the face (to the right seen from behind the
    array, i.e. towards increasing azimuth), ``y`` up along the face and the normal pointing
    at azimuth ``face_azimuth_deg``, tilted up by ``face_tilt_deg``. For zero tilt,
    ``u = cos(el) sin(az - face_az)`` and ``v = sin(el)``.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Azimuth (clockwise from north) and elevation of the directions, degrees; broadcast.
    face_azimuth_deg : float, optional
        Azimuth of the face normal, degrees.
    face_tilt_deg : float, optional
        Upward tilt of the face normal, degrees.

    Returns
    -------
    u, v, w : ndarray
        Components along the face ``x``, ``y`` and normal; ``w > 0`` in front of the face.
    """
    g = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    u, v, w = np.broadcast_arrays(g.u, g.v, g.w)
    return np.array(u), np.array(v), np.array(w)


class DualPolField(NamedTuple):
    """Far-field components of the two ports of a dual-polarised element or array.

    Components are taken on the radar's local polarisation basis at each direction:
    ``h`` is the unit vector of increasing azimuth (horizontal) and ``v`` that of increasing
    elevation.

    Attributes
    ----------
    h_co : ndarray
        H port, component along ``h`` (co-polar).
    h_cross : ndarray
        H port, component along ``v`` (cross-polar).
    v_co : ndarray
        V port, component along ``v`` (co-polar).
    v_cross : ndarray
        V port, component along ``h`` (cross-polar).
    """

    h_co: NDArray
    h_cross: NDArray
    v_co: NDArray
    v_cross: NDArray


def patch_element_field(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    patch_m: float,
    frequency_hz: float,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> DualPolField:
    """Far field of a square dual-polarised patch from the two-slot cavity model.

    Each port of a square patch of side ``L`` is modelled (Balanis, *Antenna Theory*, ch. 14,
    cavity/transmission-line model) as two in-phase radiating slots ``L`` long, a distance
    ``L`` apart, over an infinite ground plane. For the H port the patch current runs along the
    face ``x`` axis, so the equivalent magnetic currents run along ``y`` and the field is

    ``E_H = cos(k L u / 2) * sinc(k L v / 2) * (r x y_face)``, with ``|r x y_face| = sqrt(1 - v^2)``

    (the slot-pair factor gives the E-plane pattern, the slot length the H-plane one; the slot
    height is taken as negligible). The V port is the same with ``x`` and ``y`` exchanged:
    ``E_V = cos(k L v / 2) * sinc(k L u / 2) * (x_face x r)``. Both are 1 at broadside and zero
    behind the face (the ground plane blocks the rear hemisphere). The slots are at the
    patch's radiating edges with no substrate, so ``L`` is also the slot separation.

    This is the isolated-element pattern, used as the element gain pattern of the array. For
    ``L`` near half a wavelength its E-plane factor falls faster than the ``cos(theta)`` of an
    element embedded in a large matched array: at 45 degrees azimuth the H port is down
    6.6 dB and the V port 4.8 dB for the paper's 5.24 cm patch at 2.8 GHz.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Directions (absolute azimuth and elevation), degrees; broadcast together.
    patch_m : float
        Patch side ``L``, metres (the paper's patch is 0.0524 m).
    frequency_hz : float
        Frequency, Hz.
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the array face (see :func:`face_direction_cosines`).

    Returns
    -------
    DualPolField
        Real field components on the local (h, v) basis, normalised to 1 at broadside.
    """
    geometry = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    return patch_field(geometry, patch_m * frequency_hz / SPEED_OF_LIGHT)


def patch_field(g: FaceGeometry, size: float) -> DualPolField:
    """Cavity-model field of a patch ``size`` wavelengths square (see patch_element_field)."""
    front = g.w > 0.0
    # np.sinc(x) = sin(pi x) / (pi x), so sinc(k L v / 2) = np.sinc(L v / lambda).
    s_h = np.where(front, np.cos(np.pi * size * g.u) * np.sinc(size * g.v), 0.0)
    s_v = np.where(front, np.cos(np.pi * size * g.v) * np.sinc(size * g.u), 0.0)
    # Project E_H ~ r x y and E_V ~ x x r on the local basis; (v, h, r) is right-handed, so
    # (r x y)·h = y·v, (r x y)·v = -y·h, (x x r)·v = x·h and (x x r)·h = -x·v.
    return DualPolField(
        h_co=s_h * g.y_dot_v,
        h_cross=-s_h * g.y_dot_h,
        v_co=s_v * g.x_dot_h,
        v_cross=-s_v * g.x_dot_v,
    )


# --------------------------------------------------------------------------------------------
# Array weights and array factor
# --------------------------------------------------------------------------------------------


class SeparableWeights(NamedTuple):
    """Complex element weights of a planar array that factor as ``W[m, n] = x[m] * y[n]``.

    Attributes
    ----------
    x : ndarray
        Complex weights of the ``n_x`` columns (horizontal positions).
    y : ndarray
        Complex weights of the ``n_y`` rows (vertical positions).
    """

    x: NDArray[np.complex128]
    y: NDArray[np.complex128]

    def full(self) -> NDArray[np.complex128]:
        """The ``(n_x, n_y)`` weight matrix, for perturbations that break separability."""
        return np.outer(self.x, self.y)


def element_positions(n: int, spacing_m: float) -> NDArray[np.float64]:
    """Positions of ``n`` equally spaced elements centred on the array centre, metres."""
    return (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) * spacing_m


def taylor_taper(n: int, sll_db: float, nbar: int) -> NDArray[np.float64]:
    """Taylor amplitude taper of ``n`` elements (``scipy.signal.windows.taylor``).

    Parameters
    ----------
    n : int
        Number of elements.
    sll_db : float
        Design sidelobe level in dB; the sign is ignored (-30 and 30 both mean 30 dB down).
    nbar : int
        Number of nearly equal sidelobes next to the main lobe.

    Returns
    -------
    ndarray
        Real, symmetric weights.
    """
    return np.asarray(
        signal.windows.taylor(n, nbar=nbar, sll=abs(sll_db), norm=True, sym=True), dtype=float
    )


def taper_efficiency(weights: npt.ArrayLike) -> float:
    """Taper efficiency ``|sum w|^2 / (N sum |w|^2)`` of any weight vector or matrix."""
    w = np.asarray(weights)
    return float(abs(w.sum()) ** 2 / (w.size * np.sum(np.abs(w) ** 2)))


#: Amplitude tapers an array block can choose (its ``taper`` parameter).
TAPERS = ("taylor", "kaiser", "uniform")


def design_taper(
    n: int, kind: str, sll_db: float = -30.0, nbar: int = 5, beta: float = 4.0
) -> NDArray[np.float64]:
    """Amplitude taper of ``n`` elements, peak 1: Taylor (``sll_db``, ``nbar``), Kaiser
    (``beta``) or uniform, from ``scipy.signal.windows``."""
    if kind == "taylor":
        return taylor_taper(n, sll_db, nbar)
    if kind == "kaiser":
        w = signal.windows.kaiser(n, beta, sym=True)
        return np.asarray(w / w.max(), dtype=float)
    if kind == "uniform":
        return np.ones(n)
    raise ValueError(f"unknown taper {kind!r}; known: {', '.join(TAPERS)}")


def planar_array_weights(
    *,
    steer_az_deg: float,
    steer_el_deg: float,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    taylor_sll_db: float,
    taylor_nbar: int,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> SeparableWeights:
    """Taylor-tapered, phase-steered weights of a rectangular planar array.

    Ideal continuous phase shifters: element ``(m, n)`` gets the phase
    ``-k (x_m u0 + y_n v0)`` that brings all elements in phase in the steering direction, which
    keeps the weights separable. Quantised phase shifters or channel errors act on
    ``weights.full()`` and are evaluated with the general path of :func:`array_factor`.

    Parameters
    ----------
    steer_az_deg, steer_el_deg : float
        Steering direction (absolute azimuth and elevation), degrees; must be in front of the
        face.
    n_x, n_y : int
        Number of elements along the face horizontal and vertical.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored), applied separably in x and y.
    taylor_nbar : int
        Taylor ``nbar``.
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the face (see :func:`face_direction_cosines`).

    Returns
    -------
    SeparableWeights
    """
    u0, v0, w0 = face_direction_cosines(
        steer_az_deg, steer_el_deg, face_azimuth_deg=face_azimuth_deg, face_tilt_deg=face_tilt_deg
    )
    if not w0 > 0.0:
        raise ValueError(
            f"steering direction az={steer_az_deg}, el={steer_el_deg} deg is not in front of "
            f"the face (normal at az={face_azimuth_deg}, tilt={face_tilt_deg} deg)"
        )
    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    x = element_positions(n_x, dx_m)
    y = element_positions(n_y, dy_m)
    return SeparableWeights(
        x=taylor_taper(n_x, taylor_sll_db, taylor_nbar) * np.exp(-1j * k * x * u0),
        y=taylor_taper(n_y, taylor_sll_db, taylor_nbar) * np.exp(-1j * k * y * v0),
    )


def _powers(z: NDArray[np.complex128], n: int, out: NDArray[np.complex128]) -> NDArray:
    """``z[:, None] ** arange(n)`` by a running product (a complex exp per entry is 10x slower)."""
    out[:, 0] = 1.0
    out[:, 1:] = z[:, None]
    return np.cumprod(out, axis=1, out=out)


def _linear_array_factor(weights: NDArray, psi: NDArray) -> NDArray[np.complex128]:
    """``F(psi) = sum_m w_m exp(j (m - c) psi)``, ``c = (n - 1) / 2``, at any phase increments.

    ``F`` is a trigonometric polynomial with ``F(psi + 2 pi) = (-1)^(n-1) F(psi)``, so one
    zero-padded FFT tabulates it (and, with the weights multiplied by ``j (m - c)``, its
    derivative) over one period; cubic Hermite interpolation then costs a few operations per
    direction instead of one complex exponential per element and direction. Tabulating the
    centred sum rather than ``sum_m w_m exp(j m psi)`` halves its bandwidth, which cuts the
    interpolation error sixteen-fold.
    """
    weights = np.asarray(weights, dtype=complex)
    n = weights.size
    size = 1 << int(np.ceil(np.log2(max(_AF_OVERSAMPLING * n, 64))))
    centred = np.arange(n) - 0.5 * (n - 1)
    # size * ifft(a, size)[k] = sum_m a_m exp(j m psi_k) on psi_k = 2 pi k / size; the closing
    # sample k = size makes the last interval complete.
    grid_phase = np.exp(-0.5j * (n - 1) * (2.0 * np.pi / size) * np.arange(size + 1))
    spectra = np.fft.ifft(np.stack([weights, 1j * centred * weights]), size, axis=1) * size
    spectra = np.concatenate([spectra, spectra[:, :1]], axis=1) * grid_phase
    table = _hermite_table(spectra[0], spectra[1] * (2.0 * np.pi / size))
    turns = np.floor(psi / (2.0 * np.pi))
    f = _hermite_eval(table, (psi / (2.0 * np.pi) - turns) * size)
    if n % 2 == 0:
        # Half-integer element offsets: every period crossed flips the sign.
        f *= 1.0 - 2.0 * np.mod(turns, 2.0)
    return f


def _general_array_factor(weights: NDArray, psi_x: NDArray, psi_y: NDArray) -> NDArray:
    """Exact ``sum_mn W[m, n] exp(j (m - cx) psi_x + j (n - cy) psi_y)`` for any ``W``."""
    n_x, n_y = weights.shape
    flat_x, flat_y = psi_x.ravel(), psi_y.ravel()
    out = np.empty(flat_x.size, dtype=complex)
    x_pow = np.empty((_AF_CHUNK, n_x), dtype=complex)
    y_pow = np.empty((_AF_CHUNK, n_y), dtype=complex)
    # Loop over blocks of directions only; each block is two BLAS-sized products.
    for start in range(0, flat_x.size, _AF_CHUNK):
        sl = slice(start, start + _AF_CHUNK)
        count = flat_x[sl].size
        xp = _powers(np.exp(1j * flat_x[sl]), n_x, x_pow[:count])
        yp = _powers(np.exp(1j * flat_y[sl]), n_y, y_pow[:count])
        out[sl] = np.einsum("pm,pm->p", xp, yp @ weights.T)
    centre = np.exp(-0.5j * ((n_x - 1) * flat_x + (n_y - 1) * flat_y))
    return (out * centre).reshape(psi_x.shape)


def _rows_array_factor(weights: NDArray, psi_x: NDArray, psi_y: NDArray) -> NDArray:
    """Exact array factor on a grid whose ``psi_y`` is one value per row of ``psi_x``.

    The sum over the ``n_y`` rows of elements is done once per grid row (a matrix product);
    what remains per grid row is the polynomial ``sum_m B_m z^m`` in ``z = exp(j psi_x)``,
    evaluated by Horner's rule over the whole grid at once (``n_x`` contiguous multiply-adds).
    """
    n_x, n_y = weights.shape
    centred_y = np.arange(n_y) - 0.5 * (n_y - 1)
    per_row = np.exp(1j * np.outer(psi_y, centred_y)) @ weights.T  # rows x n_x
    z = np.exp(1j * psi_x)
    out = np.broadcast_to(per_row[:, n_x - 1 : n_x], psi_x.shape).astype(complex)
    for m in range(n_x - 2, -1, -1):
        out *= z
        out += per_row[:, m : m + 1]
    return out * np.exp(-0.5j * (n_x - 1) * psi_x)


def array_factor(
    u: npt.ArrayLike,
    v: npt.ArrayLike,
    weights: SeparableWeights | npt.ArrayLike,
    *,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
) -> NDArray[np.complex128]:
    """Complex array factor of a rectangular planar array, phase referenced to its centre.

    ``AF(u, v) = sum_mn W[m, n] exp(j k (x_m u + y_n v))``.

    Parameters
    ----------
    u, v : array_like
        Face direction cosines (see :func:`face_direction_cosines`); broadcast together.
    weights : SeparableWeights or array_like
        Either separable weights (fast path: ``AF_x(u) * AF_y(v)``, each from an FFT table,
        about 1e-10 relative accuracy) or a full ``(n_x, n_y)`` complex matrix (exact path,
        cost proportional to directions x elements; use it for non-separable perturbations).
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.

    Returns
    -------
    ndarray
        Complex array factor, shape of the broadcast ``u`` and ``v``; its magnitude in the
        steering direction is ``|sum W|``.
    """
    k = 2.0 * np.pi * frequency_hz / SPEED_OF_LIGHT
    psi_x = k * dx_m * np.asarray(u, dtype=float)
    psi_y = k * dy_m * np.asarray(v, dtype=float)
    if isinstance(weights, SeparableWeights):
        # Each factor on its own (unbroadcast) shape: on an az x el grid of an untilted face
        # v depends on elevation only, so AF_y costs one row instead of the whole grid.
        af_x = _linear_array_factor(weights.x, psi_x)
        af_y = _linear_array_factor(weights.y, psi_y)
        return np.asarray(af_x * af_y)
    full = np.asarray(weights, dtype=complex)
    if full.ndim != 2:
        raise ValueError(f"weights must be SeparableWeights or a 2-D matrix, got {full.shape}")
    if psi_x.ndim == 2 and psi_y.ndim == 2 and psi_y.shape[1] == 1:
        # A grid whose v depends on the row only (an untilted face): sum over rows once.
        return _rows_array_factor(full, psi_x, psi_y[:, 0])
    psi_x, psi_y = np.broadcast_arrays(psi_x, psi_y)
    return _general_array_factor(full, psi_x, psi_y)


# --------------------------------------------------------------------------------------------
# Planar array patterns
# --------------------------------------------------------------------------------------------


def planar_array_fields(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    weights: SeparableWeights | npt.ArrayLike,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> DualPolField:
    """Far field of a planar patch array for given element weights (all four components).

    Element field times array factor, normalised so that an array with the same weight
    magnitudes steered to broadside has an H co-polar amplitude of 1 on its axis. Both ports
    use the same weights; separate H and V channel errors will need one weight set per port.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Directions, degrees; broadcast together.
    weights : SeparableWeights or array_like
        Element weights (see :func:`planar_array_weights`, :func:`array_factor`).
    dx_m, dy_m, frequency_hz, patch_m : float
        Spacings (m), frequency (Hz) and patch side (m).
    face_azimuth_deg, face_tilt_deg : float, optional
        Orientation of the face.

    Returns
    -------
    DualPolField
        Complex components on the local (h, v) basis.
    """
    af, element = _array_and_element(
        az_deg, el_deg, weights, dx_m, dy_m, frequency_hz, patch_m, face_azimuth_deg, face_tilt_deg
    )
    return DualPolField(*(af * component for component in element))


def array_fields(
    geometry: FaceGeometry,
    element: object,
    weights_h: SeparableWeights | npt.ArrayLike,
    weights_v: SeparableWeights | npt.ArrayLike | None = None,
    *,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    norm: float,
) -> DualPolField:
    """Far field of a planar array with one weight set per port (all four components).

    ``AF_H E_H`` and ``AF_V E_V``, each array factor divided by ``norm`` (the design's
    broadside-steered coherent sum, so that channel errors and failures lower the peak).

    Parameters
    ----------
    geometry : FaceGeometry
        Directions in the face frame (:func:`face_geometry`).
    element : object
        Element model with ``field(geometry) -> DualPolField`` (:mod:`pasim_blocks.elements`).
    weights_h, weights_v : SeparableWeights or array_like
        Weights of the H and V ports (``weights_v`` None: the same as H).
    dx_m, dy_m, frequency_hz : float
        Spacings (m) and frequency (Hz).
    norm : float
        Divisor of both array factors.

    Returns
    -------
    DualPolField
        Complex components on the local (h, v) basis.
    """
    common = {"dx_m": dx_m, "dy_m": dy_m, "frequency_hz": frequency_hz}
    af_h = array_factor(geometry.u, geometry.v, weights_h, **common) / norm
    af_v = af_h if weights_v is None else array_factor(geometry.u, geometry.v, weights_v, **common)
    if weights_v is not None:
        af_v = af_v / norm
    e = element.field(geometry)  # type: ignore[attr-defined]
    return DualPolField(af_h * e.h_co, af_h * e.h_cross, af_v * e.v_co, af_v * e.v_cross)


def _array_and_element(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    weights: SeparableWeights | npt.ArrayLike,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    face_azimuth_deg: float,
    face_tilt_deg: float,
) -> tuple[NDArray[np.complex128], DualPolField]:
    """Normalised array factor and element field, apart so callers multiply only what they use."""
    geometry = face_geometry(az_deg, el_deg, face_azimuth_deg, face_tilt_deg)
    af = array_factor(
        geometry.u, geometry.v, weights, dx_m=dx_m, dy_m=dy_m, frequency_hz=frequency_hz
    )
    # The broadside-steered peak is sum |W| (all elements in phase, element pattern 1 there).
    if isinstance(weights, SeparableWeights):
        coherent = np.abs(weights.x).sum() * np.abs(weights.y).sum()
    else:
        coherent = np.abs(np.asarray(weights)).sum()
    af /= coherent
    return af, patch_field(geometry, patch_m * frequency_hz / SPEED_OF_LIGHT)


def planar_array_power(
    az_deg: npt.ArrayLike,
    el_deg: npt.ArrayLike,
    *,
    steer_az_deg: float,
    steer_el_deg: float,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    patch_m: float,
    taylor_sll_db: float,
    taylor_nbar: int,
    face_azimuth_deg: float = 0.0,
    face_tilt_deg: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One-way co-polar power patterns of a steered planar array of dual-polarised patches.

    Parameters
    ----------
    az_deg, el_deg : array_like
        Absolute directions (azimuth clockwise from north, elevation), degrees; broadcast.
    steer_az_deg, steer_el_deg : float
        Steering direction, degrees.
    n_x, n_y : int
        Elements along the face horizontal and vertical.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    patch_m : float
        Side of the square patch, metres.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored).
    taylor_nbar : int
        Taylor ``nbar``.
    face_azimuth_deg, face_tilt_deg : float, optional
        Azimuth and upward tilt of the face normal, degrees.

    Returns
    -------
    p_h, p_v : ndarray
        Power patterns of the H and V ports (co-polar components), both normalised to the
        peak of the broadside-steered H pattern, so scan loss shows as a peak below 1 and the
        H/V mismatch off broadside as ``p_h / p_v != 1``.
    """
    weights = planar_array_weights(
        steer_az_deg=steer_az_deg,
        steer_el_deg=steer_el_deg,
        n_x=n_x,
        n_y=n_y,
        dx_m=dx_m,
        dy_m=dy_m,
        frequency_hz=frequency_hz,
        taylor_sll_db=taylor_sll_db,
        taylor_nbar=taylor_nbar,
        face_azimuth_deg=face_azimuth_deg,
        face_tilt_deg=face_tilt_deg,
    )
    af, element = _array_and_element(
        az_deg, el_deg, weights, dx_m, dy_m, frequency_hz, patch_m, face_azimuth_deg, face_tilt_deg
    )
    # This element model is real, so |AF E|^2 = |AF|^2 E^2 and the cross-polar terms are skipped.
    af_power = af.real**2 + af.imag**2
    return np.asarray(af_power * element.h_co**2), np.asarray(af_power * element.v_co**2)


def planar_array_directivity_db(
    *,
    n_x: int,
    n_y: int,
    dx_m: float,
    dy_m: float,
    frequency_hz: float,
    taylor_sll_db: float,
    taylor_nbar: int,
) -> float:
    """Broadside directivity of a Taylor-tapered planar array from its aperture.

    ``10 log10(4 pi (n_x dx)(n_y dy) / lambda^2 * eta)`` with the taper efficiency
    ``eta = |sum w|^2 / (N sum |w|^2)`` of the separable weights.

    Parameters
    ----------
    n_x, n_y : int
        Numbers of elements.
    dx_m, dy_m : float
        Element spacings, metres.
    frequency_hz : float
        Frequency, Hz.
    taylor_sll_db : float
        Taylor design sidelobe level, dB (sign ignored).
    taylor_nbar : int
        Taylor ``nbar``.

    Returns
    -------
    float
        Directivity, dBi.
    """
    wavelength = SPEED_OF_LIGHT / frequency_hz
    area = n_x * dx_m * n_y * dy_m
    eta = taper_efficiency(taylor_taper(n_x, taylor_sll_db, taylor_nbar)) * taper_efficiency(
        taylor_taper(n_y, taylor_sll_db, taylor_nbar)
    )
    return float(10.0 * np.log10(4.0 * np.pi * area / wavelength**2 * eta))


# --------------------------------------------------------------------------------------------
# Pattern measurements on 1-D cuts
# --------------------------------------------------------------------------------------------


def _check_cut(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> tuple[NDArray, NDArray]:
    a = np.asarray(angles_deg, dtype=float)
    p = np.asarray(power, dtype=float)
    if a.ndim != 1 or a.shape != p.shape or a.size < 3:
        raise ValueError("angles_deg and power must be 1-D arrays of the same length (>= 3)")
    if np.any(np.diff(a) <= 0):
        raise ValueError("angles_deg must be strictly increasing")
    return a, p


def _parabolic_peak(p: NDArray, i: int) -> float:
    """Peak value of the parabola through samples i-1, i, i+1 (the sample value at the ends)."""
    if i == 0 or i == p.size - 1:
        return float(p[i])
    curvature = p[i + 1] - 2.0 * p[i] + p[i - 1]
    if curvature >= 0:
        return float(p[i])
    return float(p[i] - (p[i + 1] - p[i - 1]) ** 2 / (8.0 * curvature))


def half_power_beamwidth_deg(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Full width at half maximum of the main lobe of a 1-D power-pattern cut.

    The half-power crossings on either side of the highest sample are located by linear
    interpolation between samples, so the cut should sample the main lobe finely.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear, any normalisation) at those angles.

    Returns
    -------
    float
        Beamwidth, degrees.

    Raises
    ------
    ValueError
        If the pattern does not fall below half power on both sides of its peak.
    """
    a, p = _check_cut(angles_deg, power)
    i0 = int(np.argmax(p))
    half = 0.5 * p[i0]
    right = np.flatnonzero(p[i0:] < half)
    left = np.flatnonzero(p[: i0 + 1] < half)
    if right.size == 0 or left.size == 0:
        raise ValueError("the cut does not reach half power on both sides of the peak")
    j = i0 + right[0]  # first sample below half power, right of the peak
    a_right = np.interp(half, [p[j], p[j - 1]], [a[j], a[j - 1]])
    j = left[-1]  # last sample below half power, left of the peak
    a_left = np.interp(half, [p[j], p[j + 1]], [a[j], a[j + 1]])
    return float(a_right - a_left)


def first_sidelobe_db(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Level of the higher of the two first sidelobes of a 1-D power-pattern cut.

    From the highest sample the cut is followed outwards on each side to the first null
    (first local minimum) and then to the next local maximum; both maxima are refined by a
    parabola through three samples.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear) at those angles.

    Returns
    -------
    float
        First sidelobe level, dB relative to the main-lobe peak (negative).

    Raises
    ------
    ValueError
        If no sidelobe is found on either side.
    """
    _, p = _check_cut(angles_deg, power)
    peak = _parabolic_peak(p, int(np.argmax(p)))
    lo, hi = main_lobe_bounds(p)
    levels = []
    # From each first null outwards (an end of the cut when there is none).
    for side in (p[hi:], p[lo::-1]):
        falling = np.flatnonzero(np.diff(side) < 0)
        if falling.size == 0:
            continue  # no null, or still rising at the end of the cut: no resolved sidelobe
        levels.append(_parabolic_peak(side, falling[0]))
    if not levels:
        raise ValueError("no sidelobe found in the cut")
    return float(10.0 * np.log10(max(levels) / peak))


def main_lobe_bounds(power: npt.ArrayLike) -> tuple[int, int]:
    """Indices of the first minima (nulls) on either side of the highest sample of a cut.

    Where the cut is monotone to an end, that end is returned.
    """
    p = np.asarray(power, dtype=float)
    i0 = int(np.argmax(p))
    right = np.flatnonzero(np.diff(p[i0:]) > 0)
    left = np.flatnonzero(np.diff(p[i0::-1]) > 0)
    hi = i0 + int(right[0]) if right.size else p.size - 1
    lo = i0 - int(left[0]) if left.size else 0
    return lo, hi


def peak_sidelobe_db(angles_deg: npt.ArrayLike, power: npt.ArrayLike) -> float:
    """Highest level outside the main lobe (beyond the first nulls) of a 1-D power cut.

    Parameters
    ----------
    angles_deg : array_like
        Strictly increasing angles of the cut, degrees.
    power : array_like
        Power pattern (linear) at those angles.

    Returns
    -------
    float
        dB relative to the main-lobe peak (-inf when the cut has no sidelobe).
    """
    _, p = _check_cut(angles_deg, power)
    lo, hi = main_lobe_bounds(p)
    outside = np.concatenate([p[:lo], p[hi + 1 :]])
    if not outside.size or outside.max() <= 0:
        return float("-inf")
    return float(10.0 * np.log10(outside.max() / _parabolic_peak(p, int(np.argmax(p)))))
