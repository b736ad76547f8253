"""Dual-polarised radiating elements: co- and cross-polar fields of the H and V ports.

An element is a pure function of direction. It takes the directions in the frame of its face
(:func:`pasim_blocks.antennas.geometry.face_geometry`) and returns the complex far field of its two
ports on the radar's local polarisation basis (``h`` along increasing azimuth, ``v`` along
increasing elevation), normalised so that the H port's co-polar field is 1 at broadside.
What the radar calls cross-polar is the H port's ``v`` component and the V port's ``h``
component: for an element on a vertical face it is zero in the principal planes and grows off
them, as the projection of the element's own polarisation on the radar's basis.

Models:

* ``patch``: the two-slot cavity model of a square patch (Balanis, *Antenna Theory*, ch. 14),
  zero behind the ground plane. Its H port is horizontal everywhere on a vertical face; its V
  port tilts off the principal planes.
* ``crossed_dipole``: two crossed half-wave dipoles a quarter wavelength in front of a ground
  plane (image theory). Dual of the patch: its V port is pure and its H port tilts.
* ``isotropic``: unit H and V fields in front of the face, zero behind: perfect polarisation in
  the radar's basis, for reference.
* ``file``: a tabulated (measured or EM-simulated) element pattern
  (:mod:`pasim_blocks.antennas.measured`).

Any of them can add an intrinsic leakage: each port also radiates the other port's field
``cross_pol_db`` below it, with phase ``cross_pol_phase_deg``. That is the polarisation purity
of a real element (higher-order modes, probe feeds, port coupling); its cross-polar pattern has
the shape of the co-polar main lobe, the case for which Zrnic et al. (2010, JTECH 27) give the
SHV ZDR bias (docs/arrays.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .geometry import DualPolField, FaceGeometry, patch_field

#: Element models a block can choose (the ``element`` parameter).
ELEMENTS = ("patch", "crossed_dipole", "isotropic", "file")


def _front(g: FaceGeometry) -> NDArray:
    return np.asarray(g.w > 0.0)


@dataclass(frozen=True)
class PatchElement:
    """Square patch of side ``size`` wavelengths (cavity model, see ``patch_element_field``)."""

    size: float

    def field(self, g: FaceGeometry) -> DualPolField:
        return patch_field(g, self.size)


@dataclass(frozen=True)
class CrossedDipoleElement:
    """Crossed half-wave dipoles (along the face x and y axes) ``height`` wavelengths in front
    of a ground plane.

    A half-wave dipole along unit vector ``a`` radiates ``cos(pi/2 cos psi) / sin^2 psi`` times
    the transverse part ``a - (a.r) r`` (psi the angle from the dipole axis); its image in the
    ground plane adds the factor ``sin(2 pi height w)`` (w the cosine from the normal), and the
    field is normalised to 1 at broadside.
    """

    height: float = 0.25

    def field(self, g: FaceGeometry) -> DualPolField:
        front = _front(g)
        ground = np.sin(2.0 * np.pi * self.height * g.w) / np.sin(2.0 * np.pi * self.height)

        def dipole(cos_axis: NDArray) -> NDArray:
            s2 = 1.0 - cos_axis**2
            # Along the axis cos(pi c / 2) / (1 - c^2) tends to pi / 4.
            along = s2 < 1e-12
            ratio = np.where(
                along, np.pi / 4, np.cos(0.5 * np.pi * cos_axis) / np.where(along, 1, s2)
            )
            return np.where(front, ratio * ground, 0.0)

        f_x, f_y = dipole(g.u), dipole(g.v)
        # Transverse part of x (resp. y) on the local basis: x.h and x.v, since r.h = r.v = 0.
        return DualPolField(
            h_co=f_x * g.x_dot_h,
            h_cross=f_x * g.x_dot_v,
            v_co=f_y * g.y_dot_v,
            v_cross=f_y * g.y_dot_h,
        )


@dataclass(frozen=True)
class IsotropicElement:
    """Unit H and V fields on the radar's basis in front of the face, zero behind."""

    def field(self, g: FaceGeometry) -> DualPolField:
        one = np.where(_front(g), 1.0, 0.0)
        zero = np.zeros_like(one)
        return DualPolField(h_co=one, h_cross=zero, v_co=one, v_cross=zero)


@dataclass(frozen=True)
class TabulatedElement:
    """An element pattern read from a file, for faces without tilt.

    The table gives the fields against azimuth from the element normal and elevation; on an
    untilted face the element's az/el basis is the radar's, rotated about the vertical.
    """

    table: Any  # measured_pattern.TabulatedPattern

    def field(self, g: FaceGeometry) -> DualPolField:
        az = np.rad2deg(np.arctan2(g.u, g.w))
        el = np.rad2deg(np.arcsin(np.clip(g.v, -1.0, 1.0)))
        return self.table.fields(az, el, normalise="broadside")


@dataclass(frozen=True)
class LeakyElement:
    """An element whose ports also radiate each other's field, ``leakage`` (complex) below."""

    base: Any
    leakage: complex

    def field(self, g: FaceGeometry) -> DualPolField:
        f = self.base.field(g)
        x = self.leakage
        # Port H radiates E_H + x E_V: its h component gains x V_h, its v component x V_v.
        return DualPolField(
            h_co=f.h_co + x * f.v_cross,
            h_cross=f.h_cross + x * f.v_co,
            v_co=f.v_co + x * f.h_cross,
            v_cross=f.v_cross + x * f.h_co,
        )


def make_element(
    kind: str,
    *,
    patch_m: float,
    frequency_hz: float,
    cross_pol_db: float | None = None,
    cross_pol_phase_deg: float = 0.0,
    table: Any = None,
) -> Any:
    """The element of a block's parameters (``element``, ``patch_m``, ``cross_pol_db``, ...)."""
    from ..signals import SPEED_OF_LIGHT

    base: Any
    if kind == "patch":
        base = PatchElement(patch_m * frequency_hz / SPEED_OF_LIGHT)
    elif kind == "crossed_dipole":
        base = CrossedDipoleElement()
    elif kind == "isotropic":
        base = IsotropicElement()
    elif kind == "file":
        if table is None:
            raise ValueError("element 'file' needs its pattern file (parameter element_file)")
        base = TabulatedElement(table)
    else:
        raise ValueError(f"unknown element {kind!r}; known: {', '.join(ELEMENTS)}")
    if cross_pol_db is None:
        return base
    leak = 10 ** (cross_pol_db / 20) * np.exp(1j * np.deg2rad(cross_pol_phase_deg))
    return LeakyElement(base, complex(leak))
