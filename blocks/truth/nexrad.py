"""Truth: the weather as a real NEXRAD Level-II sweep sees it."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param, RunNote
from pasim_graph.fm301 import MOMENT_FIELDS, MOMENT_UNITS

from .. import DEFAULT_SCENE
from ..signals import TRUTH
from .volume import INTERPOLATIONS, covered, select_angles, volume_variables


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
    name (:mod:`pasim_blocks.truth.radar_files`); an IRIS/Sigmet ray keeps the azimuth its
    own header gives, where xradar 0.12 labels it with the next ray's
    (:mod:`pasim_blocks.truth.iris_rays`). ``fields`` names the file's variable for a moment
    where its name is not one PASIM knows (``fields: {DBZH: DBZHC}``); the file is refused,
    naming the moment and its fields, when it has no such variable. What follows describes
    Level-II.

    Reads the surveillance and Doppler cuts nearest ``elevation_deg`` (message 31, or a
    legacy message 1 file), merges them by azimuth and range, masks below-threshold and
    range-folded gates, and drops values outside physical range. Correlation coefficients
    above 1 are kept as measured. Only the records up to the end of those cuts are read,
    and with ``azimuth_start_deg``/``azimuth_stop_deg`` only the radials of that sector
    widened by ``margin_deg`` on each side.

    A truth without ZDR, RHOHV and PHIDP (a legacy single-polarisation file) has none of
    those variables, ``polarimetric = 0``, and the run gets a note that it is single
    polarisation.

    ``sweeps = volume`` reads every sweep of the volume (with ``elevation_min_deg`` and
    ``elevation_max_deg``, those within ``elevation_margin_deg`` of the scan's elevations and
    the next one either side) onto the reference sweep's grid, each gate placed in height by
    4/3-earth propagation, interpolated in elevation as ``elevation_interpolation`` says
    (:mod:`pasim_blocks.truth.volume`); the weather channel then weights it over elevation by
    the two-way pattern. The reference sweep (nearest ``elevation_deg``) stays the truth's
    ``(radial, gate)`` moments, as with one sweep.
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

    fields = Param(
        None,
        type="mapping",
        choices=MOMENT_FIELDS,
        optional=True,
        doc="moment -> the file's variable holding it, for names not known (e.g. {DBZH: "
        "DBZHC}); the other moments by name; unset: all by name",
    )

    sweeps = Param(
        "single",
        type="str",
        choices=("single", "volume"),
        doc="single: the sweep nearest elevation_deg, taken as uniform in elevation; volume: "
        "every sweep, interpolated in elevation",
    )
    elevation_interpolation = Param(
        "nearest",
        type="str",
        choices=INTERPOLATIONS,
        doc="volume: between sweeps, nearest (each sweep stands for the elevations nearer it "
        "than any other, as its own beam measured them) or linear (the two either side mixed)",
    )
    elevation_min_deg = Param(
        None,
        units="deg",
        min=-2.0,
        max=90.0,
        optional=True,
        doc="volume: lowest beam elevation of the scan (with elevation_max_deg: only the "
        "sweeps it needs are read; unset: all)",
    )
    elevation_max_deg = Param(
        None,
        units="deg",
        min=-2.0,
        max=90.0,
        optional=True,
        doc="volume: highest beam elevation of the scan (with elevation_min_deg)",
    )
    elevation_margin_deg = Param(
        1.5,
        units="deg",
        min=0.0,
        max=45.0,
        doc="volume: sweeps within this of the scan's elevations are read (the pattern's "
        "support in elevation that matters: 1.25 deg for a 1 deg pencil beam at the weather "
        "channel's elevation_support_db of -60 dB; wider beams need more)",
    )
    sweep_beamwidth_deg = Param(
        1.0,
        units="deg",
        min=0.01,
        max=10.0,
        doc="volume: each sweep stands for the elevations within half of this; below the "
        "lowest sweep's and above the top sweep's there is no echo",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        low, high = params.get("elevation_min_deg"), params.get("elevation_max_deg")
        if (low is None) != (high is None):
            given = "elevation_min_deg" if high is None else "elevation_max_deg"
            return [(f"parameter '{given}'", "needs the other end too (or neither: all sweeps)")]
        if low is not None and high is not None and low > high:
            return [("parameter 'elevation_min_deg'", f"{low:g} is above elevation_max_deg")]
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
        fields = self.p["fields"]
        if fields and is_level2(path):
            raise ValueError(
                f"{path}: a NEXRAD Level-II volume names its moments itself (REF, ZDR, RHO, "
                f"PHI, VEL, SW); parameter 'fields' of block '{self.name}' applies to files in "
                "other formats: leave it unset"
            )
        if self.p["sweeps"] == "volume":
            sweep, volume = self._volume(path)
        elif is_level2(path):
            # Level-II through the project's own reader (it beats xradar's there); any other
            # radar file through xradar's backend for its format.
            sweep = read_truth_sweep(
                path,
                self.p["elevation_deg"],
                sector_deg=self.sector(),
                margin_deg=self.p["margin_deg"],
            )
            volume = None
        else:
            sweep = read_radar_sweep(
                path,
                self.p["elevation_deg"],
                sector_deg=self.sector(),
                margin_deg=self.p["margin_deg"],
                fields=fields,
            )
            volume = None
        present = [name for name in POLARIMETRIC_FIELDS if name in sweep.fields]
        if not present:
            warnings.warn(
                f"truth {sweep.source}: no polarimetric fields (ZDR, RHOHV, PHIDP); "
                "running single polarisation (H channel only)" + _unmapped(sweep, "ZDR"),
                RunNote,
                stacklevel=2,
            )
        elif not sweep.polarimetric:
            absent = [n for n in POLARIMETRIC_FIELDS if n not in present]
            warnings.warn(
                f"truth {sweep.source}: polarimetric fields incomplete (no {', '.join(absent)})"
                + _unmapped(sweep, absent[0]),
                RunNote,
                stacklevel=2,
            )
        if "WRADH" not in sweep.fields or "VRADH" not in sweep.fields:
            doppler = [n for n in ("VRADH", "WRADH") if n not in sweep.fields]
            warnings.warn(
                f"truth {sweep.source}: no {' or '.join(doppler)}; the weather channel takes "
                "velocity 0 m/s and width 1 m/s there, and they are not scored"
                + _unmapped(sweep, doppler[0]),
                RunNote,
                stacklevel=2,
            )
        # One sweep is the resource as it always was; a volume adds its variables.
        return sweep if volume is None else (sweep, volume)

    def _volume(self, path: Any) -> tuple[Any, Any]:
        """The reference sweep and the volume's variables (only the sweeps the scan needs)."""
        from .gridding import check_sector
        from .nexrad_io import read_truth_sweeps, volume_angles
        from .radar_files import damaged, is_level2, open_radar_file, sweeps_from_tree
        from .rhi_files import only_rhis, rhi_sweeps

        low, high = self.p["elevation_min_deg"], self.p["elevation_max_deg"]
        margin = self.p["elevation_margin_deg"]
        wanted = float(self.p["elevation_deg"])

        def choose(angles: list[float]) -> list[float]:
            chosen = select_angles(
                angles,
                None if low is None else low - margin,
                None if high is None else high + margin,
            )
            reference = min(angles, key=lambda a: abs(a - wanted))
            if abs(reference - wanted) > 1.0:
                raise ValueError(
                    f"{path}: no sweep within 1 deg of elevation_deg {wanted:g} (the reference "
                    "sweep); fixed angles (deg): " + ", ".join(f"{a:.2f}" for a in angles)
                )
            return sorted(set(chosen) | {reference})

        sector, sector_margin = self.sector(), self.p["margin_deg"]
        if is_level2(path):
            angles = volume_angles(path)
            read = read_truth_sweeps(path, choose(angles), sector, sector_margin)
        else:
            angles = []

            def remember(available: list[float]) -> list[float]:
                angles.extend(available)
                return choose(available)

            tree, kind = open_radar_file(path)
            fields = self.p["fields"]
            if only_rhis(tree, f"{path} ({kind})"):
                # RHIs: their rays regrouped by elevation, over the RHIs' own azimuths.
                read = rhi_sweeps(tree, kind, Path(path), remember, fields)
            else:
                limits = check_sector(sector, sector_margin)
                read = sweeps_from_tree(tree, kind, Path(path), remember, *limits, fields)
        chosen = choose(angles)
        reference = read[int(np.argmin([abs(a - wanted) for a in chosen]))]
        width = float(self.p["sweep_beamwidth_deg"])
        with damaged(f"{path}: its sweeps as a volume", str(path)):
            variables, attrs = volume_variables(
                read, reference, self.p["elevation_interpolation"], width
            )
        lo, hi = covered(variables["sweep_elevation"][1], width)
        warnings.warn(
            f"truth {reference.source}: volume of {len(read)} sweeps ("
            + ", ".join(f"{s.elevation_deg:.2f}" for s in sorted(read, key=_elevation))
            + f" deg) of the file's {len(angles)}; no echo below {lo:.2f} or above {hi:.2f} deg "
            "elevation (nothing is invented outside the sweeps)",
            RunNote,
            stacklevel=2,
        )
        return reference, (variables, attrs)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        resource = chunk.resource
        sweep, volume = resource if isinstance(resource, tuple) else (resource, None)
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
        if volume is not None:
            variables, attrs = volume
            ds = ds.assign(variables)
            ds.attrs.update(attrs)
        return {"truth": ds}


def _unmapped(sweep: Any, moment: str) -> str:
    """The tail of a note on a missing moment: the file's fields no moment was taken from,
    and how to name one (nothing for a file without such fields, e.g. Level-II)."""
    from .radar_files import mapping_hint

    names = list(sweep.unmapped)
    if not names:
        return ""
    return f" (its fields not known by name: {', '.join(names)}; {mapping_hint(moment, names)})"


def _elevation(sweep: Any) -> float:
    return float(sweep.elevation_deg)
