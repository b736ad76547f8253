"""Arrays of any geometry as blocks: a line, a ring or arc, a planar lattice, and a file of
element positions and normals, each one :class:`~.conformal.ConformalArray` given its
:class:`~.layouts.Layout` (docs/arrays.md)."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Param

from .conformal import ConformalArray
from .layouts import Layout

_FACE_AZIMUTH = Param(
    285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the array face normal"
)
_FACE_TILT = Param(0.0, units="deg", min=-30.0, max=60.0, doc="upward tilt of the face")
_ACTIVE_SECTOR = Param(
    90.0,
    units="deg",
    min=0.1,
    max=360.0,
    doc="azimuth span of the columns that form a beam, centred on it (360: every column)",
)


def _get(cls: type, params: dict[str, Any]) -> Any:
    return lambda name: params.get(name, cls.params[name].default)  # type: ignore[attr-defined]


def _divides(get: Any, whole: str, part: str) -> list[tuple[str, str]]:
    n, sub = get(whole), get(part)
    if isinstance(n, int) and isinstance(sub, int) and n % sub:
        return [(f"parameter {part!r}", f"{sub} does not divide the {n} elements of {whole}")]
    return []


def _sector_taper(get: Any) -> list[tuple[str, str]]:
    if get("taper") != "uniform" and get("active_sector_deg") > 180.0:
        return [
            (
                "parameter 'active_sector_deg'",
                f"{get('active_sector_deg'):g} deg folds the columns' positions across the beam; "
                f"a {get('taper')} taper needs a sector of at most 180 deg (or taper 'uniform')",
            )
        ]
    return []


class _Face(ConformalArray):
    """An array on one flat face: every element faces the face's normal."""

    face_azimuth_deg = _FACE_AZIMUTH
    face_tilt_deg = _FACE_TILT

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        out = super().check_config(params, connected)
        get = _get(cls, params)
        if get("element") == "file" and get("face_tilt_deg") != 0:
            out.append(
                ("parameter 'face_tilt_deg'", "a tabulated element needs an untilted face (0)")
            )
        return out

    @classmethod
    def steering_problems(
        cls, params: dict[str, Any], azimuth_deg: np.ndarray, elevation_deg: np.ndarray
    ) -> list[tuple[str, str]]:
        from .geometry import behind_face

        get = _get(cls, params)
        text = behind_face(
            azimuth_deg, elevation_deg, float(get("face_azimuth_deg")), float(get("face_tilt_deg"))
        )
        return [] if text is None else [("steering", text)]

    def broadside(self) -> tuple[float, float]:
        return float(self.p["face_azimuth_deg"]), float(self.p["face_tilt_deg"])


class LinearArray(_Face):
    """A uniformly spaced line of dual-polarised elements across a face, steered electronically.

    ``elements`` elements ``spacing_m`` apart along the face's horizontal axis, each facing the
    face normal, tapered across the line, ``subarray`` consecutive elements behind each T/R
    channel. A line has no aperture up: its elevation pattern is the element's.
    """

    elements = Param(32, type="int", min=1, max=100_000, doc="elements in the line")
    spacing_m = Param(0.0535, units="m", min=1e-3, max=10.0, doc="element spacing")
    subarray = Param(1, type="int", min=1, max=100_000, doc="consecutive elements per channel")

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        return super().check_config(params, connected) + _divides(
            _get(cls, params), "elements", "subarray"
        )

    def build_layout(self, resource: Any) -> Layout:
        from .layouts import linear_layout

        p = self.p
        return linear_layout(
            p["elements"], p["spacing_m"], p["face_azimuth_deg"], p["face_tilt_deg"], p["subarray"]
        )


class LatticeArray(_Face):
    """A planar array on a rectangular or triangular lattice, steered electronically.

    ``n_x`` columns ``spacing_x_m`` apart across the face, each of ``n_y`` elements
    ``spacing_y_m`` apart up it; on a triangular lattice every other column is raised half a
    spacing (its elements between those of its neighbours). Tapered across the columns and up
    them; ``subarray_x`` by ``subarray_y`` elements behind each T/R channel. On a rectangular
    lattice it is ``antenna.planar``'s array (without its mutual-coupling model) computed
    element by element.
    """

    n_x = Param(16, type="int", min=1, max=4096, doc="columns across (azimuth)")
    n_y = Param(16, type="int", min=1, max=4096, doc="elements up each column (elevation)")
    spacing_x_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="column spacing across")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    lattice = Param(
        "rectangular",
        type="str",
        choices=("rectangular", "triangular"),
        doc="rectangular, or triangular (every other column raised half a spacing)",
    )
    subarray_x = Param(1, type="int", min=1, max=4096, doc="columns per subarray")
    subarray_y = Param(1, type="int", min=1, max=4096, doc="elements up per subarray")

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        get = _get(cls, params)
        return (
            super().check_config(params, connected)
            + _divides(get, "n_x", "subarray_x")
            + _divides(get, "n_y", "subarray_y")
        )

    def build_layout(self, resource: Any) -> Layout:
        from .layouts import lattice_layout

        p = self.p
        return lattice_layout(
            p["n_x"],
            p["n_y"],
            p["spacing_x_m"],
            p["spacing_y_m"],
            p["face_azimuth_deg"],
            p["face_tilt_deg"],
            p["lattice"],
            p["subarray_x"],
            p["subarray_y"],
        )


class RingArray(ConformalArray):
    """A ring, an arc of a ring, or a cylinder or cylindrical arc of columns.

    ``elements`` columns at the centres of equal cells of an arc of ``arc_deg`` (360: the full
    ring) of radius ``radius_m`` centred on ``centre_azimuth_deg``, each facing out along its
    radius; each column holds ``elements_per_column`` elements ``spacing_y_m`` apart up (1: a
    ring). A beam is formed by the columns within ``active_sector_deg / 2`` of its azimuth
    (commutated round the ring), ``subarray`` consecutive columns behind each T/R channel.
    """

    elements = Param(96, type="int", min=1, max=100_000, doc="columns round the ring or arc")
    radius_m = Param(0.8, units="m", min=0.01, max=100.0, doc="radius of the ring")
    arc_deg = Param(360.0, units="deg", min=0.1, max=360.0, doc="arc the columns fill (360: ring)")
    centre_azimuth_deg = Param(
        285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the arc's centre (broadside)"
    )
    elements_per_column = Param(1, type="int", min=1, max=4096, doc="elements up each column")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    subarray = Param(1, type="int", min=1, max=100_000, doc="consecutive columns per channel")
    active_sector_deg = _ACTIVE_SECTOR

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        get = _get(cls, params)
        out = super().check_config(params, connected) + _divides(get, "elements", "subarray")
        return out + _sector_taper(get)

    @classmethod
    def steering_problems(
        cls, params: dict[str, Any], azimuth_deg: np.ndarray, elevation_deg: np.ndarray
    ) -> list[tuple[str, str]]:
        get = _get(cls, params)
        arc, sector = float(get("arc_deg")), float(get("active_sector_deg"))
        if arc >= 360.0 or sector >= 360.0:
            return []
        centre = float(get("centre_azimuth_deg"))
        off = (np.asarray(azimuth_deg, float) - centre + 180.0) % 360.0 - 180.0
        # Columns stand from -arc/2 + cell/2 to arc/2 - cell/2: a beam further than sector/2
        # beyond the last column has none.
        last = arc / 2 - arc / int(get("elements")) / 2
        outside = np.abs(off) >= last + sector / 2
        if not outside.any():
            return []
        return [
            (
                "steering",
                f"{int(outside.sum())} of the scan's {outside.size} beams (azimuth "
                f"{float(np.asarray(azimuth_deg)[outside][0]):g} deg, ...) have no column of the "
                f"{arc:g} deg arc centred on {centre:g} deg within {sector / 2:g} deg",
            )
        ]

    def beam_sector_deg(self) -> float:
        return float(self.p["active_sector_deg"])

    def broadside(self) -> tuple[float, float]:
        return float(self.p["centre_azimuth_deg"]), 0.0

    def build_layout(self, resource: Any) -> Layout:
        from .layouts import ring_layout

        p = self.p
        return ring_layout(
            p["elements"],
            p["radius_m"],
            p["arc_deg"],
            p["centre_azimuth_deg"],
            p["elements_per_column"],
            p["spacing_y_m"],
            p["subarray"],
        )


class ElementFileArray(ConformalArray):
    """A conformal array read from a file of element positions and outward normals.

    One element a line of ``path`` (comma-separated: ``x_m,y_m,z_m,normal_x,normal_y,normal_z``
    east-north-up, and optionally ``channel``, the T/R channel it is behind; format in
    docs/arrays.md). Each element's pattern is turned to its own normal; a beam is formed by
    the elements whose normal's azimuth is within ``active_sector_deg / 2`` of the beam's.
    """

    path = Param("", type="path", doc="element file: positions and outward normals (CSV)")
    active_sector_deg = _ACTIVE_SECTOR
    broadside_azimuth_deg = Param(
        0.0, units="deg", min=0.0, max=360.0, doc="azimuth of broadside (pattern command, norm)"
    )
    broadside_elevation_deg = Param(
        0.0, units="deg", min=-90.0, max=90.0, doc="elevation of broadside"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        get = _get(cls, params)
        out = super().check_config(params, connected) + _sector_taper(get)
        if not get("path"):
            out.append(("parameter 'path'", "needs the element file (positions and normals)"))
        return out

    def needs_resource(self) -> bool:
        return True

    def load(self) -> Any:
        from .layouts import layout_from_elements, read_element_file

        positions, normals, channels = read_element_file(self.p["path"])
        layout = layout_from_elements(
            positions, normals, channels, f"element file {self.p['path']}"
        )
        return layout, super().load()

    def build_layout(self, resource: Any) -> Layout:
        if resource is None:
            raise ValueError(f"antenna {self.name!r}: its element file is read by load() first")
        return resource[0]  # type: ignore[no-any-return]

    def element_table(self, resource: Any) -> Any:
        return None if resource is None else resource[1]

    def beam_sector_deg(self) -> float:
        return float(self.p["active_sector_deg"])

    def broadside(self) -> tuple[float, float]:
        return float(self.p["broadside_azimuth_deg"]), float(self.p["broadside_elevation_deg"])
