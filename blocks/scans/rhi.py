"""An RHI: beams at one azimuth, stepping in elevation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..angles import nearest_radial
from ..cf import cf_attributes
from ..signals import BEAMS, TRUTH
from .beams import beam_dataset, seconds, site_and_start


def rhi_elevations(start_deg: float, stop_deg: float, step_deg: float) -> np.ndarray:
    """Beam elevations from ``start_deg`` up to ``stop_deg`` (included when the step lands on
    it), ``step_deg`` apart."""
    n = math.floor((stop_deg - start_deg) / step_deg + 1e-9) + 1
    return start_deg + step_deg * np.arange(max(n, 1))


class RHIScan(Block):
    """A range-height indicator scan: beams at one azimuth from ``elevation_start_deg`` up to
    ``elevation_stop_deg``, ``elevation_step_deg`` apart, each dwelling ``pulses`` pulses of
    ``prt_s``. With the truth connected and ``align_to_truth`` set, the azimuth is the nearest
    truth radial's. The sweep's FM-301 ``sweep_mode`` is ``rhi`` and its fixed angle the
    azimuth; the store lays its beams along ``elevation``, and ``pasim plot`` draws it as
    range against height.
    """

    role = "scan"
    beam_source = True

    truth = Input(TRUTH, required=False, doc="truth sweep, for site, time and alignment")
    beams = Output(BEAMS, store="moments", doc="geometry of the beams in the chunk")

    azimuth_deg = Param(285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the RHI")
    elevation_start_deg = Param(0.5, units="deg", min=-2.0, max=90.0, doc="lowest beam")
    elevation_stop_deg = Param(20.0, units="deg", min=-2.0, max=90.0, doc="highest beam")
    elevation_step_deg = Param(
        0.5, units="deg", min=0.01, max=30.0, doc="elevation step between beams"
    )
    pulses = Param(64, type="int", min=2, max=4096, doc="pulses per dwell (M)")
    prt_s = Param(1 / 300, units="s", min=1e-5, max=0.1, doc="pulse repetition time")
    align_to_truth = Param(True, type="bool", doc="point the RHI at the nearest truth radial")
    time_offset_s = Param(
        0.0,
        units="s",
        min=0.0,
        max=1e6,
        doc="start of the sweep after the truth's start (a volume sets it for each sweep)",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        def get(name: str) -> Any:
            return params.get(name, cls.params[name].default)

        start, stop = get("elevation_start_deg"), get("elevation_stop_deg")
        if stop < start:
            return [
                (
                    "parameter 'elevation_stop_deg'",
                    f"the RHI goes up from elevation_start_deg {start:g} deg: "
                    f"elevation_stop_deg {stop:g} deg is below it",
                )
            ]
        return []

    def setup(self) -> None:
        self._cf = cf_attributes()
        self.elevations = rhi_elevations(
            self.p["elevation_start_deg"],
            self.p["elevation_stop_deg"],
            self.p["elevation_step_deg"],
        )

    def beam_count(self) -> int:
        return int(self.elevations.size)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        az = float(self.p["azimuth_deg"]) % 360.0
        truth = inputs.get("truth")
        if truth is not None and self.p["align_to_truth"]:
            radials = truth["azimuth"].values
            az = float(radials[nearest_radial(np.array([az]), radials)[0]])
        start, site = site_and_start(inputs, self.p["time_offset_s"])
        beams = chunk.beams
        dwell = self.p["pulses"] * self.p["prt_s"]
        ds = beam_dataset(
            self._cf,
            azimuth=np.full(beams.size, az),
            elevation=self.elevations[beams],
            time=start + (beams * dwell * 1e9).astype("timedelta64[ns]"),
            prt=np.full(beams.size, self.p["prt_s"]),
            pulses=int(self.p["pulses"]),
            scan_rate=np.full(beams.size, self.p["elevation_step_deg"] / dwell),
            sweep_mode="rhi",
            fixed_angle=az,
            start=start,
            end=start + seconds(self.elevations.size * dwell),
            site=site,
            rate_name="elevation rate of the scan",
        )
        ds["sweep_fixed_angle"].attrs = {
            "units": "degrees",
            "long_name": "fixed azimuth of the RHI",
        }
        return {"beams": ds}
