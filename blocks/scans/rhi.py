"""An RHI: beams at one azimuth, stepping in elevation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pasim_graph import Chunk, Param
from pasim_graph.fm301 import SWEEP_MODE_RHI

from ..angles import nearest_radial
from .beam_geometry import beam_dataset, seconds, site_and_start
from .scan import DwellScan


def rhi_elevations(start_deg: float, stop_deg: float, step_deg: float) -> np.ndarray:
    """Beam elevations from ``start_deg`` up to ``stop_deg`` (included when the step lands on
    it), ``step_deg`` apart."""
    n = math.floor((stop_deg - start_deg) / step_deg + 1e-9) + 1
    return start_deg + step_deg * np.arange(max(n, 1))


class RHIScan(DwellScan):
    """A range-height indicator scan: beams at one azimuth from ``elevation_start_deg`` up to
    ``elevation_stop_deg``, ``elevation_step_deg`` apart, each dwelling ``pulses`` pulses of
    ``prt_s``. With the truth connected and ``align_to_truth`` set, the azimuth is the nearest
    truth radial's. The sweep's FM-301 ``sweep_mode`` is ``rhi`` and its fixed angle the
    azimuth; the store lays its beams along ``elevation``, and ``pasim plot`` draws it as
    range against height.
    """

    azimuth_deg = Param(285.0, units="deg", min=0.0, max=360.0, doc="azimuth of the RHI")
    elevation_start_deg = Param(0.5, units="deg", min=-2.0, max=90.0, doc="lowest beam")
    elevation_stop_deg = Param(20.0, units="deg", min=-2.0, max=90.0, doc="highest beam")
    elevation_step_deg = Param(
        0.5, units="deg", min=0.01, max=30.0, doc="elevation step between beams"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        start = cls.given(params, "elevation_start_deg")
        stop = cls.given(params, "elevation_stop_deg")
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
        super().setup()
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
            sweep_mode=SWEEP_MODE_RHI,
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
