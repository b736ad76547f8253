"""The pencil beam: a tapered circular aperture, as pure functions of direction.

:class:`PencilBeam` is the "generic radar" of the PASIM paper (Table 4): a circular aperture
with the illumination taper ``g(rho) = (1 - rho**2)**p``, whose exponent ``p`` is solved for the
requested first sidelobe and whose diameter is solved for the requested 3-dB beamwidth. Its
field pattern has the closed form ``E(u) = Gamma(nu + 1) (2/u)**nu J_nu(u)`` with
``nu = p + 1`` and ``u = pi D sin(theta)/lambda``. Angles are in degrees.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from .hermite import hermite_eval, hermite_table

# Largest taper exponent the designer will use. p = 20 already gives a first sidelobe near
# -103 dB, far beyond any real reflector, so the limit only guards the root finder.
_MAX_TAPER_EXPONENT = 20.0
# Step of the pencil-beam lookup table in u. With cubic Hermite interpolation and exact slopes
# the amplitude error is below step**4 / 384 * max|E''''| ~ 3e-10 (E'''' <= 1/8 at u = 0).
_PENCIL_TABLE_STEP = 1.0 / 32.0


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
    # scipy is imported where it is used, here and below: at the top, every command that
    # only reads a graph (validate, blocks, --help) paid for importing it.
    from scipy import special

    out[~small] = np.exp(special.gammaln(nu + 1.0) + nu * np.log(2.0 / ul)) * special.jv(nu, ul)
    return out


def _first_bessel_zero(order: float) -> float:
    """First positive zero of J_order for real order >= 0 (scipy only tabulates integer orders)."""
    # j_{nu,1} lies in (nu, nu + 20) for every order the designer can reach (nu <= 23).
    from scipy import optimize, special

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
    from scipy import optimize

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
        object.__setattr__(self, "_table", hermite_table(values, slopes))

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
            from scipy import optimize

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
        return hermite_eval(self._table, u / _PENCIL_TABLE_STEP)

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
