"""Antennas: one-way H and V patterns around each beam's axis.

A pattern is sampled on a grid of azimuth and elevation offsets from the beam axis and
normalised to the antenna's peak gain (``gain_db`` attribute), so that scan loss and H/V
mismatch off broadside show as values below 1 and as P_H != P_V. The weather channel squares
``power`` (the same antenna transmits and receives) and integrates it over each truth cell.
Array antennas also give the complex co- and cross-polar voltage patterns of both ports
(``co_polar``, ``cross_polar``), from which the two-way coupling of SHV and AHV transmission
follows (``pasim_blocks.polarimetry``, docs/arrays.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param

from .signals import BEAMS, PATTERN, POLARIZATIONS

#: Parameters several antennas declare alike (each class gets its own named copy).
PATTERN_SUPPORT = Param(
    10.0, units="deg", min=0.5, max=45.0, doc="half-width of the pattern grid around the beam axis"
)
PATCH_SIDE = Param(
    0.0524, units="m", min=1e-3, max=1.0, doc="side of the square patch (paper Table 1)"
)

# ---- parameters shared by the array antennas ---------------------------------------------------

ELEMENT = Param(
    "patch",
    type="str",
    choices=("patch", "crossed_dipole", "isotropic", "file"),
    doc="radiating element: cavity-model patch, crossed dipoles, isotropic, or element_file",
)
ELEMENT_FILE = Param(
    "",
    type="path",
    doc="element pattern file (element 'file'; format in docs/arrays.md)",
)
CROSS_POL = Param(
    None,
    units="dB",
    min=-100.0,
    max=0.0,
    optional=True,
    doc="intrinsic leakage: each port also radiates the other's field this far below (unset: none)",
)
CROSS_POL_PHASE = Param(
    0.0, units="deg", min=-180.0, max=180.0, doc="phase of the intrinsic cross-polar leakage"
)
TAPER = Param(
    "taylor", type="str", choices=("taylor", "kaiser", "uniform"), doc="amplitude taper family"
)
KAISER_BETA = Param(4.0, min=0.0, max=20.0, doc="Kaiser taper beta (taper 'kaiser')")
AMPLITUDE_ERROR = Param(
    0.0, units="dB", min=0.0, max=10.0, doc="channel-to-channel amplitude error, rms"
)
PHASE_ERROR = Param(0.0, units="deg", min=0.0, max=180.0, doc="channel-to-channel phase error, rms")
FAILURES = Param(0.0, min=0.0, max=0.99, doc="probability that a T/R module has failed")
PHASE_BITS = Param(
    0, type="int", min=0, max=16, doc="phase shifter bits (0: continuous, ideal phase shifters)"
)
ATTENUATOR_BITS = Param(
    0, type="int", min=0, max=16, doc="attenuator bits for the taper (0: continuous)"
)
ATTENUATOR_LSB = Param(0.5, units="dB", min=0.01, max=10.0, doc="attenuator step")
RANDOMIZE = Param(
    False,
    type="bool",
    doc="randomise the quantisation (known random insertion phases): no quantisation lobes",
)
ERRORS_SEED = Param(
    None,
    type="int",
    min=0,
    optional=True,
    doc="seed of the channel errors (unset: drawn from the run seed)",
)
CALIBRATION = Param(
    "per_beam",
    type="str",
    choices=("per_beam", "boresight"),
    doc="radar constant per beam from its own two-way pattern, or the broadside one for all",
)


def offsets(support_deg: float, step_deg: float) -> np.ndarray:
    n = int(np.ceil(support_deg / step_deg))
    return np.arange(-n, n + 1) * step_deg


def two_way_solid_angle(
    power: np.ndarray, d_az: np.ndarray, d_el: np.ndarray, elevation_deg: float
) -> float:
    """Integral of the two-way power pattern over the grid, in steradians."""
    step = np.deg2rad(d_az[1] - d_az[0]) * np.deg2rad(d_el[1] - d_el[0])
    cos_el = np.cos(np.deg2rad(elevation_deg + d_el))[:, None]
    return float(np.sum(power.astype(np.float64) ** 2 * cos_el) * step)


def pattern_dataset(
    power: np.ndarray,
    d_az: np.ndarray,
    d_el: np.ndarray,
    gain_db: float,
    solid_angle_sr: dict[str, float],
    *,
    calibration_sr: np.ndarray | None = None,
    co_polar: np.ndarray | None = None,
    cross_polar: np.ndarray | None = None,
    **attrs: Any,
) -> xr.Dataset:
    """The pattern port's Dataset.

    ``solid_angle_sr`` holds the boresight (broadside) two-way solid angles; ``calibration_sr``
    (beam x polarisation) the per-beam ones, when the antenna calibrates per beam (otherwise
    every beam gets the boresight value).
    """
    dims = ("beam", "polarization", "elevation_offset", "azimuth_offset")
    boresight = np.tile([solid_angle_sr[p] for p in POLARIZATIONS], (power.shape[0], 1))
    variables: dict[str, Any] = {
        "power": (dims, power, {"units": "1"}),
        "calibration_solid_angle_sr": (
            ("beam", "polarization"),
            boresight if calibration_sr is None else np.asarray(calibration_sr, np.float64),
            {"units": "sr"},
        ),
    }
    if co_polar is not None:
        variables["co_polar"] = (dims, co_polar.astype(np.complex64), {"units": "1"})
    if cross_polar is not None:
        variables["cross_polar"] = (dims, cross_polar.astype(np.complex64), {"units": "1"})
    return xr.Dataset(
        variables,
        coords={
            "polarization": list(POLARIZATIONS),
            "azimuth_offset_deg": ("azimuth_offset", d_az, {"units": "degrees"}),
            "elevation_offset_deg": ("elevation_offset", d_el, {"units": "degrees"}),
        },
        attrs={
            "gain_db": gain_db,
            "calibration": "boresight" if calibration_sr is None else "per_beam",
            **{f"two_way_solid_angle_sr_{p}": v for p, v in solid_angle_sr.items()},
            **attrs,
        },
    )


class AxisymmetricAntenna(Block):
    """Base of antennas whose pattern depends only on the angle off the beam axis.

    Subclasses give ``amplitude_off_axis(theta_deg)`` (the one-way field, 1 on the axis); the
    pattern on the offset grid is computed once per beam elevation (azimuth offsets shrink
    into smaller angles as the beam rises, by cos el), H and V are identical, there is no
    cross-polar field and the antenna is steered mechanically, so every beam at one elevation
    has the same pattern.
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V power patterns around each beam axis")

    beamwidth_deg = Param(1.0, units="deg", min=0.01, max=30.0, doc="one-way 3-dB beamwidth")
    gain_db = Param(45.5, units="dB", min=0.0, max=70.0, doc="peak gain")
    grid_step_deg = Param(0.05, units="deg", min=0.001, max=1.0, doc="pattern grid step")

    @classmethod
    def warm_up(cls) -> None:
        from . import patterns  # noqa: F401

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def power_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.amplitude_off_axis(theta_deg) ** 2

    def setup(self) -> None:
        self.d_az = offsets(self.p["support_deg"], self.p["grid_step_deg"])
        self.d_el = self.d_az.copy()
        self._by_elevation: dict[float, np.ndarray] = {}
        self.omega = two_way_solid_angle(self._power(0.0), self.d_az, self.d_el, 0.0)

    def broadside(self) -> tuple[float, float]:
        """Direction of the beam axis the pattern command calls broadside (az, el)."""
        return 0.0, 0.0

    def pattern_gain_db(self, resource: Any = None) -> float:
        """Peak gain the pattern is normalised to (dBi)."""
        return float(self.p["gain_db"])

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        """One-way fields of both ports at absolute directions, for a beam at (az, el)."""
        from .patterns import DualPolField

        theta = _off_axis_deg(steer_az_deg, steer_el_deg, az_deg, el_deg)
        a = self.amplitude_off_axis(theta).astype(complex)
        zero = np.zeros_like(a)
        return DualPolField(h_co=a, h_cross=zero, v_co=a, v_cross=zero)

    def _power(self, elevation_deg: float) -> np.ndarray:
        if elevation_deg not in self._by_elevation:
            theta = _off_axis_deg(
                0.0, elevation_deg, self.d_az[None, :], elevation_deg + self.d_el[:, None]
            )
            self._by_elevation[elevation_deg] = self.power_off_axis(theta).astype(np.float32)
        return self._by_elevation[elevation_deg]

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        elevations = inputs["beams"]["elevation"].values
        shape = (2, self.d_el.size, self.d_az.size)
        power = np.stack([np.broadcast_to(self._power(float(e)), shape) for e in elevations])
        ds = pattern_dataset(
            power,
            self.d_az,
            self.d_el,
            self.p["gain_db"],
            {p: self.omega for p in POLARIZATIONS},
            antenna=self.type_name or type(self).__name__,
        )
        return {"pattern": ds}


def _off_axis_deg(
    axis_az_deg: float, axis_el_deg: float, az_deg: np.ndarray, el_deg: np.ndarray
) -> np.ndarray:
    """Great-circle angle between the axis and each direction, degrees."""
    el0 = np.deg2rad(axis_el_deg)
    el = np.deg2rad(np.asarray(el_deg, dtype=float))
    d_az = np.deg2rad(np.asarray(az_deg, dtype=float) - axis_az_deg)
    cos_t = np.sin(el0) * np.sin(el) + np.cos(el0) * np.cos(el) * np.cos(d_az)
    return np.rad2deg(np.arccos(np.clip(cos_t, -1.0, 1.0)))


class PencilBeamAntenna(AxisymmetricAntenna):
    """A mechanically steered pencil beam: the same pattern at every azimuth (generic radar).

    Circular aperture whose (1 - rho^2)^p taper is solved to give ``first_sidelobe_db``,
    scaled to ``beamwidth_deg``; H and V patterns are identical.
    """

    beamwidth_deg = Param(1.0, units="deg", min=0.1, max=30.0, doc="one-way 3-dB beamwidth")
    first_sidelobe_db = Param(
        -32.0, units="dB", min=-60.0, max=-17.6, doc="first sidelobe level, one-way"
    )
    support_deg = PATTERN_SUPPORT

    def setup(self) -> None:
        from .patterns import PencilBeam

        self.beam = PencilBeam.design(self.p["beamwidth_deg"], self.p["first_sidelobe_db"])
        super().setup()

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.beam.amplitude(theta_deg)


class IdealAntenna(AxisymmetricAntenna):
    """A pencil beam with no sidelobes: a Gaussian main lobe, for estimator studies.

    One-way power exp(-4 ln 2 theta^2 / beamwidth^2) of the angle theta off the axis, cut to
    zero beyond ``support_deg``; H and V identical.
    """

    support_deg = Param(
        2.0,
        units="deg",
        min=0.05,
        max=45.0,
        doc="half-width of the pattern grid (the beam is zero beyond)",
    )

    def amplitude_off_axis(self, theta_deg: np.ndarray) -> np.ndarray:
        amplitude = np.exp(-2 * np.log(2) * (theta_deg / self.p["beamwidth_deg"]) ** 2)
        return np.where(theta_deg > self.p["support_deg"], 0.0, amplitude)


class ArrayAntenna(Block):
    """Base of the electronically steered arrays: element, channel electronics, calibration.

    Subclasses implement ``fields_at`` (one-way complex fields of both ports at absolute
    directions for a beam steered to (az, el)), ``broadside`` and ``channel_shape`` (the grid
    of T/R channels whose errors are drawn).
    """

    beams = Input(BEAMS, doc="beam geometry")
    pattern = Output(PATTERN, doc="one-way H and V co- and cross-polar patterns per beam")

    element = ELEMENT
    element_file = ELEMENT_FILE
    patch_m = PATCH_SIDE
    cross_pol_db = CROSS_POL
    cross_pol_phase_deg = CROSS_POL_PHASE
    amplitude_error_db = AMPLITUDE_ERROR
    phase_error_deg = PHASE_ERROR
    failure_probability = FAILURES
    phase_bits = PHASE_BITS
    attenuator_bits = ATTENUATOR_BITS
    attenuator_lsb_db = ATTENUATOR_LSB
    randomize_quantization = RANDOMIZE
    errors_seed = ERRORS_SEED
    calibration = CALIBRATION

    transient = ("_draws",)

    @classmethod
    def warm_up(cls) -> None:
        from . import electronics, elements, patterns  # noqa: F401

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        element = params.get("element", cls.params["element"].default)
        path = params.get("element_file", "")
        if element == "file" and not path:
            return [("parameter 'element_file'", "element 'file' needs a pattern file")]
        if path and element != "file":
            return [("parameter 'element_file'", f"is set but element is {element!r}, not 'file'")]
        return []

    def setup(self) -> None:
        from .electronics import ChannelModel

        self.channel = ChannelModel.from_params(self.p)
        self._draws: dict[int, Any] | None = {}

    def load(self) -> Any:
        if self.p["element"] != "file":
            return None
        from .measured_pattern import read_pattern_file

        return read_pattern_file(self.p["element_file"])

    def make_element(self, resource: Any) -> Any:
        from .elements import make_element

        return make_element(
            self.p["element"],
            patch_m=self.p["patch_m"],
            frequency_hz=self.p["frequency_hz"],
            cross_pol_db=self.p["cross_pol_db"],
            cross_pol_phase_deg=self.p["cross_pol_phase_deg"],
            table=resource,
        )

    def channel_shape(self) -> tuple[int, ...]:
        raise NotImplementedError

    def pattern_gain_db(self, resource: Any = None) -> float:
        """Broadside directivity of the ideal array, which the patterns are normalised to."""
        return float(self.gain_db)

    def broadside(self) -> tuple[float, float]:
        raise NotImplementedError

    def fields_at(
        self,
        steer_az_deg: float,
        steer_el_deg: float,
        az_deg: np.ndarray,
        el_deg: np.ndarray,
        seed: int = 0,
        resource: Any = None,
    ) -> Any:
        raise NotImplementedError

    def draw(self, seed: int) -> Any:
        """The channel errors of the array built with run seed ``seed`` (None: no random part)."""
        from .electronics import array_rng

        if not self.channel.random:
            return None
        if self._draws is None:  # dropped when the block was pickled to a worker
            self._draws = {}
        key = int(seed) if self.p["errors_seed"] is None else -1
        if key not in self._draws:
            rng = array_rng(seed, self.name, self.p["errors_seed"])
            self._draws[key] = self.channel.draw(self.channel_shape(), rng)
        return self._draws[key]

    def beam_grid(
        self, az_deg: float, el_deg: float, seed: int, resource: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """Co- and cross-polar fields (polarisation, el, az) of one beam on the offset grid."""
        f = self.fields_at(
            az_deg,
            el_deg,
            az_deg + self.d_az[None, :],
            el_deg + self.d_el[:, None],
            seed,
            resource,
        )
        shape = (self.d_el.size, self.d_az.size)
        co = np.stack([np.broadcast_to(f.h_co, shape), np.broadcast_to(f.v_co, shape)])
        cross = np.stack([np.broadcast_to(f.h_cross, shape), np.broadcast_to(f.v_cross, shape)])
        return co, cross

    def pattern_output(
        self,
        beams: xr.Dataset,
        co: np.ndarray,
        cross: np.ndarray,
        **attrs: Any,
    ) -> xr.Dataset:
        """The pattern Dataset of a chunk from its fields (beam, polarisation, el, az)."""
        power = (co.real**2 + co.imag**2).astype(np.float32)
        calibration_sr = None
        if self.p["calibration"] == "per_beam":
            elevations = beams["elevation"].values
            calibration_sr = np.array(
                [
                    [
                        two_way_solid_angle(power[b, i], self.d_az, self.d_el, float(e))
                        for i in (0, 1)
                    ]
                    for b, e in enumerate(elevations)
                ]
            )
        return pattern_dataset(
            power,
            self.d_az,
            self.d_el,
            self.gain_db,
            self.omega,
            calibration_sr=calibration_sr,
            co_polar=co,
            cross_polar=cross,
            **attrs,
        )


class PlanarPatchArray(ArrayAntenna):
    """A planar array of dual-polarised elements, tapered, steered electronically.

    Elements sit on an ``n_x`` by ``n_y`` grid in a vertical face whose normal points at
    ``face_azimuth_deg``, grouped into subarrays of ``subarray_x`` by ``subarray_y``. Each beam
    is steered by phase weights, per element (a T/R module behind every element) or per
    subarray (one T/R module per subarray behind a passive divider that keeps the taper, so
    the subarray's elements are in phase). The channel electronics (errors, failures,
    quantised phase shifters and attenuators, ``pasim_blocks.electronics``) act on those T/R
    channels, per port. Patterns are normalised to the ideal array's broadside peak, so scan
    loss, beam broadening, the H/V mismatch that biases ZDR off broadside, and the gain lost
    to errors and failures all appear.
    """

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
        if get("element") == "file" and get("face_tilt_deg") != 0:
            out.append(
                ("parameter 'face_tilt_deg'", "a tabulated element needs an untilted face (0)")
            )
        return out

    def setup(self) -> None:
        from .patterns import SPEED_OF_LIGHT, taper_efficiency

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
        self.omega: dict[str, float] = {}
        if p["element"] != "file":
            self._broadside_solid_angles(None)

    def _taper(self, n: int) -> np.ndarray:
        from .patterns import design_taper

        p = self.p
        return design_taper(n, p["taper"], p["taylor_sll_db"], p["taylor_nbar"], p["kaiser_beta"])

    def _broadside_solid_angles(self, resource: Any) -> None:
        az, el = self.broadside()
        ideal = _ideal_copy(self)
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

    def channel_shape(self) -> tuple[int, ...]:
        p = self.p
        if p["steering"] == "subarray":
            return (p["n_x"] // p["subarray_x"], p["n_y"] // p["subarray_y"])
        return (p["n_x"], p["n_y"])

    def _positions(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions (x, y) whose phases steer each element: its own, or its subarray's centre."""
        from .patterns import element_positions

        p = self.p
        x = element_positions(p["n_x"], p["spacing_x_m"])
        y = element_positions(p["n_y"], p["spacing_y_m"])
        if p["steering"] == "subarray":
            x = np.repeat(x.reshape(-1, p["subarray_x"]).mean(axis=1), p["subarray_x"])
            y = np.repeat(y.reshape(-1, p["subarray_y"]).mean(axis=1), p["subarray_y"])
        return x, y

    def weights(self, steer_az_deg: float, steer_el_deg: float, seed: int = 0) -> tuple[Any, Any]:
        """Realised H and V weights for a beam (V None: the same as H)."""
        from .patterns import SeparableWeights, face_direction_cosines

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
        from .patterns import array_fields, face_geometry

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
        grids = [
            self.beam_grid(float(a), float(e), chunk.seed, chunk.resource)
            for a, e in zip(beams["azimuth"].values, beams["elevation"].values, strict=True)
        ]
        co = np.stack([g[0] for g in grids])
        cross = np.stack([g[1] for g in grids])
        return {"pattern": self.pattern_output(beams, co, cross, antenna="planar")}


def _ideal_copy(block: ArrayAntenna) -> ArrayAntenna:
    """The same array with ideal channel electronics (the design the errors perturb), built
    once per block."""
    from .electronics import IDEAL

    if block.channel.ideal:
        return block
    if getattr(block, "_ideal", None) is None:
        block._ideal = type(block)(name=block.name, **{**block.p, **IDEAL})
    return block._ideal
