"""Truth: the weather as a real NEXRAD Level-II sweep sees it."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param

from . import DEFAULT_SCENE
from .signals import TRUTH


class NexradTruth(Block):
    """Fields of one NEXRAD Level-II sweep, split cuts merged, cleaned, on their polar grid.

    Reads the surveillance and Doppler cuts nearest ``elevation_deg`` (xradar), merges them by
    azimuth so the six moments are present, masks below-threshold and range-folded gates, and
    drops values outside physical range. Correlation coefficients above 1 are kept as measured.

    Outputs
    -------
    truth : truth_sweep
        DBZH, ZDR, RHOHV, PHIDP, VRADH, WRADH (radial x gate, NaN where no data), with the
        radial azimuths, gate ranges, radial width and the site as attributes.
    """

    role = "truth"

    truth = Output(TRUTH, doc="truth fields on the radar's polar grid")

    path = Param("", type="path", doc="NEXRAD Level-II file; empty = the bundled KLBB scene")
    elevation_deg = Param(
        0.5, units="deg", min=-2.0, max=90.0, doc="elevation of the sweep to use (nearest cut)"
    )

    def load(self) -> Any:
        from .nexrad_io import read_truth_sweep

        return read_truth_sweep(self.p["path"] or DEFAULT_SCENE, self.p["elevation_deg"])

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        sweep = chunk.resource
        ds = xr.Dataset(
            {
                name: (("radial", "gate"), np.asarray(values, dtype=np.float32))
                for name, values in sweep.fields.items()
            },
            coords={
                "azimuth": ("radial", np.asarray(sweep.azimuth_deg, dtype=np.float64)),
                "range": ("gate", np.asarray(sweep.range_m, dtype=np.float64)),
            },
            attrs={
                "elevation_deg": float(sweep.elevation_deg),
                "radial_width_deg": float(sweep.radial_width_deg),
                "gate_width_m": float(sweep.gate_width_m),
                "nyquist_velocity_ms": float(sweep.nyquist_velocity_ms),
                "source": str(sweep.source),
                **{k: v for k, v in sweep.site.items()},
            },
        )
        return {"truth": ds}
