"""The planar patch array: one flat face of T/R channels (paper Table 1)."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Param

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


class PlanarPatchArray(ArrayAntenna):
    """A planar array of dual-polarised elements, tapered, steered electronically.

    Elements sit on an ``n_x`` by ``n_y`` grid in a vertical face whose normal points at
    ``face_azimuth_deg``, grouped into subarrays of ``subarray_x`` by ``subarray_y``. Each beam
    is steered by phase weights, per element (a T/R module behind every element) or per
    subarray (one T/R module per subarray behind a passive divider that keeps the taper, so
    the subarray's elements are in phase). The channel electronics (errors, failures,
    quantised phase shifters and attenuators, ``pasim_blocks.antennas.electronics``) act on those
    T/R channels, per port. Patterns are normalised to the ideal array's broadside peak, so scan
    loss, beam broadening, the H/V mismatch that biases ZDR off broadside, and the gain lost
    to errors and failures all appear. ``coupling`` puts the elements inside their array:
    the mismatch of the lattice's mutual coupling for each scan direction, from a file of
    S-parameters or Wheeler's sheet model (``pasim_blocks.antennas.coupling``), and
    ``embedded_pattern: cell`` the cos(theta) pattern of a large array's embedded element.
    """

    @classmethod
    def warm_up(cls) -> None:
        super().warm_up()
        from . import coupling  # noqa: F401  (its elements are made per chunk)

    frequency_hz = Param(2.8e9, units="Hz", min=1e8, max=1e11, doc="carrier frequency")
    n_x = Param(80, type="int", min=1, max=4096, doc="elements across (azimuth)")
    n_y = Param(80, type="int", min=1, max=4096, doc="elements up (elevation)")
    spacing_x_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing across")
    spacing_y_m = Param(0.0524, units="m", min=1e-3, max=10.0, doc="element spacing up")
    subarray_x = Param(1, type="int", min=1, max=4096, doc="elements across per subarray")
    subarray_y = Param(1, type="int", min=1, max=4096, doc="elements up per subarray")
    steering = Param(
        "element",
        type="str",
        choices=("element", "subarray"),
        doc="T/R modules and phase shifters per element or per subarray",
    )
    taper = TAPER
    taylor_sll_db = Param(
        -30.0, units="dB", min=-80.0, max=-13.0, doc="Taylor taper sidelobe level (both axes)"
    )
    taylor_nbar = Param(5, type="int", min=1, max=50, doc="Taylor taper nbar")
    kaiser_beta = KAISER_BETA
    face_azimuth_deg = Param(
        285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the array face normal"
    )
    face_tilt_deg = Param(0.0, units="deg", min=-30.0, max=60.0, doc="upward tilt of the face")
    support_deg = PATTERN_SUPPORT
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")
    coupling = Param(
        "none",
        type="str",
        choices=("none", "model", "file"),
        doc="mutual coupling: none (isolated elements), model (Wheeler sheet) or coupling_file",
    )
    coupling_file = Param(
        "", type="path", doc="lattice S-parameters (coupling 'file'; format in docs/arrays.md)"
    )
    embedded_pattern = Param(
        "isolated",
        type="str",
        choices=("isolated", "cell"),
        doc="pattern inside the array: the isolated element's, or the cell's cos(theta)",
    )
    coupling_radius = Param(
        31, type="int", min=1, max=64, doc="offsets (elements) the coupling model keeps"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        out = super().check_config(params, connected)

        def get(name: str) -> Any:
            return params.get(name, cls.params[name].default)

        for axis in ("x", "y"):
            n, sub = get(f"n_{axis}"), get(f"subarray_{axis}")
            if isinstance(n, int) and isinstance(sub, int) and n % sub:
                out.append(
                    (
                        f"parameter 'subarray_{axis}'",
                        f"{sub} does not divide the {n} elements of n_{axis}",
                    )
                )
        from .coupling import check_coupling

        out += check_coupling(get)
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

        def get(name: str) -> Any:
            return params.get(name, cls.params[name].default)

        text = behind_face(
            azimuth_deg, elevation_deg, float(get("face_azimuth_deg")), float(get("face_tilt_deg"))
        )
        return [] if text is None else [("steering", text)]

    def setup(self) -> None:
        from ..signals import SPEED_OF_LIGHT
        from .tapers import taper_efficiency

        super().setup()
        p = self.p
        for axis in ("x", "y"):
            if p[f"n_{axis}"] % p[f"subarray_{axis}"]:
                raise ValueError(
                    f"subarray_{axis}={p[f'subarray_{axis}']} does not divide "
                    f"n_{axis}={p[f'n_{axis}']}"
                )
        self.d_az = offsets(p["support_deg"], p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self.k = 2 * np.pi * p["frequency_hz"] / SPEED_OF_LIGHT
        self.taper_x = self._taper(p["n_x"])
        self.taper_y = self._taper(p["n_y"])
        self.norm = float(self.taper_x.sum() * self.taper_y.sum())
        wavelength = SPEED_OF_LIGHT / p["frequency_hz"]
        area = p["n_x"] * p["spacing_x_m"] * p["n_y"] * p["spacing_y_m"]
        eta = taper_efficiency(self.taper_x) * taper_efficiency(self.taper_y)
        # Broadside directivity of the aperture (design_taper: the amplitude the design asks).
        self.gain_db = float(10 * np.log10(4 * np.pi * area / wavelength**2 * eta))
        self.lattice: Any = None
        if p["coupling"] == "file":
            from .coupling import read_coupling_file

            self.lattice = read_coupling_file(p["coupling_file"])
        self.omega: dict[str, float] = {}
        if p["element"] != "file":
            self._broadside_solid_angles(None)

    def make_element(self, resource: Any) -> Any:
        """The element, inside its array when ``coupling`` is set (``coupling.py``)."""
        from .coupling import embed

        element = super().make_element(resource)
        return embed(element, self.p, self.taper_x, self.taper_y, self.lattice)

    def _taper(self, n: int) -> np.ndarray:
        from .tapers import design_taper

        p = self.p
        return design_taper(n, p["taper"], p["taylor_sll_db"], p["taylor_nbar"], p["kaiser_beta"])

    def _broadside_solid_angles(self, resource: Any) -> None:
        az, el = self.broadside()
        ideal = ideal_copy(self)
        if ideal is not self:
            if not ideal.omega:
                ideal._broadside_solid_angles(resource)
            self.omega = ideal.omega
            return
        co, _ = ideal.beam_grid(az, el, 0, resource)
        power = co.real**2 + co.imag**2
        self.omega = {
            pol: two_way_solid_angle(power[i], self.d_az, self.d_el, el)
            for i, pol in enumerate(POLARIZATIONS)
        }

    def broadside(self) -> tuple[float, float]:
        return float(self.p["face_azimuth_deg"]), float(self.p["face_tilt_deg"])

    def element_layout(self) -> Any:
        """The elements' positions, normals and T/R channels as a :class:`~.layouts.Layout`
        (what ``antenna.lattice`` computes element by element; the sums here stay separable)."""
        from .layouts import lattice_layout

        p = self.p
        sub = p["steering"] == "subarray"
        return lattice_layout(
            p["n_x"],
            p["n_y"],
            p["spacing_x_m"],
            p["spacing_y_m"],
            p["face_azimuth_deg"],
            p["face_tilt_deg"],
            "rectangular",
            p["subarray_x"] if sub else 1,
            p["subarray_y"] if sub else 1,
        )

    def channel_shape(self) -> tuple[int, ...]:
        p = self.p
        if p["steering"] == "subarray":
            return (p["n_x"] // p["subarray_x"], p["n_y"] // p["subarray_y"])
        return (p["n_x"], p["n_y"])

    def _positions(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions (x, y) whose phases steer each element: its own, or its subarray's centre."""
        from .tapers import element_positions

        p = self.p
        x = element_positions(p["n_x"], p["spacing_x_m"])
        y = element_positions(p["n_y"], p["spacing_y_m"])
        if p["steering"] == "subarray":
            x = np.repeat(x.reshape(-1, p["subarray_x"]).mean(axis=1), p["subarray_x"])
            y = np.repeat(y.reshape(-1, p["subarray_y"]).mean(axis=1), p["subarray_y"])
        return x, y

    def weights(self, steer_az_deg: float, steer_el_deg: float, seed: int = 0) -> tuple[Any, Any]:
        """Realised H and V weights for a beam (V None: the same as H)."""
        from .geometry import face_direction_cosines
        from .tapers import SeparableWeights

        p = self.p
        u0, v0, w0 = face_direction_cosines(
            steer_az_deg,
            steer_el_deg,
            face_azimuth_deg=p["face_azimuth_deg"],
            face_tilt_deg=p["face_tilt_deg"],
        )
        if not w0 > 0.0:
            raise ValueError(
                f"steering direction az={steer_az_deg}, el={steer_el_deg} deg is not in front of "
                f"the face (normal at az={p['face_azimuth_deg']}, tilt={p['face_tilt_deg']} deg)"
            )
        x, y = self._positions()
        phase_x, phase_y = -self.k * x * float(u0), -self.k * y * float(v0)
        if self.channel.ideal:
            weights = SeparableWeights(
                self.taper_x * np.exp(1j * phase_x), self.taper_y * np.exp(1j * phase_y)
            )
            return weights, None
        draw = self.draw(seed)
        taper = np.outer(self.taper_x, self.taper_y)
        if p["steering"] == "subarray":
            sx, sy = p["subarray_x"], p["subarray_y"]
            commanded = np.add.outer(phase_x[::sx], phase_y[::sy])
            out = [
                taper
                * np.kron(
                    self.channel.weights(np.ones_like(commanded), commanded, draw, i),
                    np.ones((sx, sy)),
                )
                for i in (0, 1)
            ]
        else:
            commanded = np.add.outer(phase_x, phase_y)
            out = [self.channel.weights(taper, commanded, draw, i) for i in (0, 1)]
        return out[0], (None if draw is None else out[1])

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        from .array_factor import array_fields
        from .geometry import face_geometry

        p = self.p
        w_h, w_v = self.weights(steer_az_deg, steer_el_deg, seed)
        geometry = face_geometry(az_deg, el_deg, p["face_azimuth_deg"], p["face_tilt_deg"])
        return array_fields(
            geometry,
            self.make_element(resource),
            w_h,
            w_v,
            dx_m=p["spacing_x_m"],
            dy_m=p["spacing_y_m"],
            frequency_hz=p["frequency_hz"],
            norm=self.norm,
        )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams"]
        if not self.omega:
            self._broadside_solid_angles(chunk.resource)
        co, cross = self.beam_grids(*steering(beams), chunk.seed, chunk.resource)
        return {"pattern": self.pattern_output(beams, co, cross, antenna="planar")}
