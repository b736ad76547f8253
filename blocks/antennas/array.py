"""The electronically steered arrays' common base: element, channel electronics, calibration."""

from __future__ import annotations

from typing import Any, ClassVar, TypeVar, cast

import numpy as np
import xarray as xr

from pasim_graph import Input, Output

from ..signals import BEAMS, PATTERN
from .antenna import Antenna
from .base import (
    AMPLITUDE_ERROR,
    ATTENUATOR_BITS,
    ATTENUATOR_LSB,
    CALIBRATION,
    CROSS_POL,
    CROSS_POL_PHASE,
    ELEMENT,
    ELEMENT_FILE,
    ERRORS_SEED,
    FAILURES,
    PATCH_SIDE,
    PHASE_BITS,
    PHASE_ERROR,
    RANDOMIZE,
    pattern_dataset,
    steering,
    two_way_solid_angle,
)

_A = TypeVar("_A", bound="ArrayAntenna")


class ArrayAntenna(Antenna):
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

    transient: ClassVar[tuple[str, ...]] = ("_draws",)

    # Set by each array's setup (its pattern grid, broadside gain and two-way solid angles per
    # polarisation), read by the code here.
    d_az: np.ndarray
    d_el: np.ndarray
    gain_db: float
    omega: dict[str, float]
    _ideal: ArrayAntenna | None

    @classmethod
    def warm_up(cls) -> None:
        from . import (
            array_factor,  # noqa: F401
            electronics,  # noqa: F401
            elements,  # noqa: F401
        )

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
        from .pattern_files import read_pattern_file

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

    def ideal_copy(self) -> ArrayAntenna | None:
        """The same array with ideal channel electronics (None: its electronics are ideal)."""
        return None if self.channel.ideal else ideal_copy(self)

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

    def beam_fields(
        self, az_deg: float, el_deg: float, seed: int, resource: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """H and V co-polar, then H and V cross-polar fields of one beam on the offset grid,
        each broadcastable to (el, az)."""
        f = self.fields_at(
            az_deg,
            el_deg,
            az_deg + self.d_az[None, :],
            el_deg + self.d_el[:, None],
            seed,
            resource,
        )
        return f.h_co, f.v_co, f.h_cross, f.v_cross

    def beam_grid(
        self, az_deg: float, el_deg: float, seed: int, resource: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """Co- and cross-polar fields (polarisation, el, az) of one beam on the offset grid."""
        co, cross = self.beam_grids(np.array([az_deg]), np.array([el_deg]), seed, resource)
        return co[0], cross[0]

    def beam_grids(
        self, az_deg: np.ndarray, el_deg: np.ndarray, seed: int, resource: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`beam_grid` of every beam, written into one (beam, polarisation, el, az) pair
        of arrays (no per-beam copies stacked afterwards: a chunk's grids are tens of MB)."""
        shape = (az_deg.size, 2, self.d_el.size, self.d_az.size)
        co: np.ndarray | None = None
        cross: np.ndarray | None = None
        for b, (az, el) in enumerate(zip(az_deg, el_deg, strict=True)):
            h_co, v_co, h_cross, v_cross = self.beam_fields(float(az), float(el), seed, resource)
            if co is None or cross is None:
                co = np.empty(shape, np.result_type(h_co, v_co))
                cross = np.empty(shape, np.result_type(h_cross, v_cross))
            co[b, 0], co[b, 1] = h_co, v_co
            cross[b, 0], cross[b, 1] = h_cross, v_cross
        if co is None or cross is None:  # no beams
            return np.empty(shape, complex), np.empty(shape, complex)
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
            elevations = steering(beams)[1]
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


def ideal_copy(block: _A) -> _A:
    """The same array with ideal channel electronics (the design the errors perturb), built
    once per block."""
    from .electronics import IDEAL

    if block.channel.ideal:
        return block
    if getattr(block, "_ideal", None) is None:
        block._ideal = type(block)(name=block.name, **{**block.p, **IDEAL})
    return cast(_A, block._ideal)
