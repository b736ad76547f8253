"""Truth: the weather as a real NEXRAD Level-II sweep sees it."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param, RunNote

from .. import DEFAULT_SCENE
from ..signals import MOMENT_UNITS, TRUTH


def truth_dataset(
    fields: dict[str, np.ndarray], azimuth_deg: np.ndarray, range_m: np.ndarray, **attrs: Any
) -> xr.Dataset:
    """The truth port's Dataset: moments on (radial, gate) with their units, and the grid."""
    return xr.Dataset(
        {
            name: (("radial", "gate"), np.asarray(v, np.float32), {"units": MOMENT_UNITS[name]})
            for name, v in fields.items()
        },
        coords={
            "azimuth": ("radial", np.asarray(azimuth_deg, np.float64), {"units": "degrees"}),
            "range": ("gate", np.asarray(range_m, np.float64), {"units": "meters"}),
        },
        attrs=attrs,
    )


class NexradTruth(Block):
    """Fields of one radar sweep (NEXRAD Level-II split cuts merged), cleaned, on their polar grid.

    A file in another format (CfRadial 1 and 2, ODIM_H5, IRIS/Sigmet, UF, Rainbow, GAMIC,
    Furuno) is read through xradar, its fields mapped onto the six moments by name or standard
    name (:mod:`pasim_blocks.truth.radar_files`); what follows describes Level-II.

    Reads the surveillance and Doppler cuts nearest ``elevation_deg`` (message 31, or a
    legacy message 1 file), merges them by azimuth and range, masks below-threshold and
    range-folded gates, and drops values outside physical range. Correlation coefficients
    above 1 are kept as measured. Only the records up to the end of those cuts are read,
    and with ``azimuth_start_deg``/``azimuth_stop_deg`` only the radials of that sector
    widened by ``margin_deg`` on each side.

    A truth without ZDR, RHOHV and PHIDP (a legacy single-polarisation file) has none of
    those variables, ``polarimetric = 0``, and the run gets a note that it is single
    polarisation.
    """

    role = "truth"

    truth = Output(TRUTH, doc="truth fields on the radar's polar grid")

    path = Param(
        "",
        type="path",
        doc=(
            "radar file: NEXRAD Level-II, or any format xradar reads (CfRadial, ODIM_H5, "
            "IRIS, UF, ...); empty = the bundled KLBB scene"
        ),
    )
    elevation_deg = Param(
        0.5, units="deg", min=-2.0, max=90.0, doc="elevation of the sweep to use (nearest cut)"
    )
    azimuth_start_deg = Param(
        None,
        units="deg",
        min=0.0,
        max=360.0,
        optional=True,
        doc="read radials from this azimuth clockwise (with azimuth_stop_deg; unset: all)",
    )
    azimuth_stop_deg = Param(
        None,
        units="deg",
        min=0.0,
        max=360.0,
        optional=True,
        doc="read radials up to this azimuth (with azimuth_start_deg; unset: all)",
    )
    margin_deg = Param(
        10.0,
        units="deg",
        min=0.0,
        max=180.0,
        doc=(
            "half-width of the widest antenna pattern support you expect; radials within "
            "this of the sector are read too"
        ),
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        start, stop = params.get("azimuth_start_deg"), params.get("azimuth_stop_deg")
        if (start is None) != (stop is None):
            given, missing = (
                ("azimuth_start_deg", "azimuth_stop_deg")
                if stop is None
                else ("azimuth_stop_deg", "azimuth_start_deg")
            )
            return [(f"parameter '{given}'", f"needs '{missing}' too (or neither: all radials)")]
        return []

    def sector(self) -> tuple[float, float] | None:
        """The azimuth sector to read, or None for the whole sweep.

        Equal start and stop mean the full circle, as for the scan.
        """
        start, stop = self.p["azimuth_start_deg"], self.p["azimuth_stop_deg"]
        if start is None or stop is None or (stop - start) % 360.0 == 0.0:
            return None
        return (float(start), float(stop))

    def load(self) -> Any:
        from .nexrad_io import POLARIMETRIC_FIELDS, read_truth_sweep
        from .radar_files import is_level2, read_radar_sweep

        path = self.p["path"] or DEFAULT_SCENE
        # Level-II through the project's own reader (it beats xradar's there); any other
        # radar file through xradar's backend for its format.
        reader = read_truth_sweep if is_level2(path) else read_radar_sweep
        sweep = reader(
            path,
            self.p["elevation_deg"],
            sector_deg=self.sector(),
            margin_deg=self.p["margin_deg"],
        )
        present = [name for name in POLARIMETRIC_FIELDS if name in sweep.fields]
        if not present:
            warnings.warn(
                f"truth {sweep.source}: no polarimetric fields (ZDR, RHOHV, PHIDP); "
                "running single polarisation (H channel only)",
                RunNote,
                stacklevel=2,
            )
        elif not sweep.polarimetric:
            missing = ", ".join(n for n in POLARIMETRIC_FIELDS if n not in present)
            warnings.warn(
                f"truth {sweep.source}: polarimetric fields incomplete (no {missing})",
                RunNote,
                stacklevel=2,
            )
        if "WRADH" not in sweep.fields or "VRADH" not in sweep.fields:
            doppler = [n for n in ("VRADH", "WRADH") if n not in sweep.fields]
            warnings.warn(
                f"truth {sweep.source}: no {' or '.join(doppler)}; the weather channel takes "
                "velocity 0 m/s and width 1 m/s there, and they are not scored",
                RunNote,
                stacklevel=2,
            )
        return sweep

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        sweep = chunk.resource
        ds = truth_dataset(
            sweep.fields,
            sweep.azimuth_deg,
            sweep.range_m,
            elevation_deg=float(sweep.elevation_deg),
            radial_width_deg=float(sweep.radial_width_deg),
            gate_width_m=float(sweep.gate_width_m),
            nyquist_velocity_ms=float(sweep.nyquist_velocity_ms),
            polarimetric=int(sweep.polarimetric),
            source=str(sweep.source),
            **sweep.site,
        )
        return {"truth": ds}
