"""Scan strategies: which beams the radar forms, where, and for how long."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Param
from pasim_graph.fm301 import PRT_MODE_FIXED, PRT_MODE_STAGGERED, SWEEP_MODE_PPI
from pasim_graph.scores import mean_prt

from ..angles import circular_difference, nearest_radial
from ..timing import STAGGERS, draw_code_errors, sz_code
from .beam_geometry import beam_dataset, seconds, site_and_start
from .platform import PlatformParams, carry
from .scan import DwellScan


class PPISector(PlatformParams, DwellScan):
    """A PPI sector scan: beams at one elevation across an azimuth sector.

    Beams are spaced ``beam_spacing_deg`` apart from ``azimuth_start_deg`` clockwise to
    ``azimuth_stop_deg`` (a sector may wrap through north), each dwelling ``pulses`` pulses of
    ``prt_s``. When the truth is connected and ``align_to_truth`` is set, each beam points at
    the nearest truth radial, so the scores compare a beam with the radial it is centred on.
    0 to 360 deg is the full circle; a sector whose ends are equal, or narrower than one beam
    spacing, is refused at validation.

    On a platform (``platform`` other than none, :mod:`pasim_blocks.scans.platform`) the
    sector is steered in the array's frame (azimuth from the platform's nose, elevation above
    its deck) and each beam is carried to the earth's through the platform's attitude at the
    middle of its dwell; the beams then carry the platform's velocity and are not pointed at
    the truth's radials.
    """

    azimuth_start_deg = Param(
        240.0,
        units="deg",
        min=0.0,
        max=360.0,
        doc="first edge of the sector (clockwise from north)",
    )
    azimuth_stop_deg = Param(330.0, units="deg", min=0.0, max=360.0, doc="last edge of the sector")
    beam_spacing_deg = Param(1.0, units="deg", min=0.01, max=30.0, doc="azimuth step between beams")
    elevation_deg = Param(0.5, units="deg", min=-2.0, max=90.0, doc="beam elevation")
    stagger = Param(
        "uniform",
        type="str",
        choices=("uniform", *STAGGERS),
        doc="PRT scheme: uniform, or staggered with T1/T2 = 2/3 or 3/4 (prt_s is T1)",
    )
    phase_code = Param(
        "none",
        type="str",
        choices=("none", "sz8_64", "random"),
        doc="transmit phase code: none, SZ(8/64) (Sachidananda and Zrnic 1999), or random",
    )
    phase_code_error_deg = Param(
        0.0,
        units="deg",
        min=0.0,
        max=45.0,
        doc="rms error of each coded pulse's transmitted phase (independent per pulse; the "
        "echoes carry it, the receiver decodes with the ideal code)",
    )
    phase_code_ripple_db = Param(
        0.0,
        units="dB",
        min=0.0,
        max=10.0,
        doc="rms amplitude ripple of the coded pulses (independent per pulse)",
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        start = cls.given(params, "azimuth_start_deg")
        stop = cls.given(params, "azimuth_stop_deg")
        step = cls.given(params, "beam_spacing_deg")
        sector = f"the sector {start:g} to {stop:g} deg"
        if stop - start != 360.0 and (stop - start) % 360.0 == 0.0:
            # setup() would read equal ends as the full circle: refused, since it is more
            # likely a mistake than a way of asking for 360 deg.
            return [
                (
                    "parameter 'azimuth_stop_deg'",
                    f"{sector} starts and stops at the same azimuth and holds no beam; for the "
                    "full circle give azimuth_start_deg 0 and azimuth_stop_deg 360",
                )
            ]
        if cls.given(params, "phase_code") == "none":
            for name in ("phase_code_error_deg", "phase_code_ripple_db"):
                value = cls.given(params, name)
                if isinstance(value, (int, float)) and value != 0:
                    return [
                        (
                            f"parameter '{name}'",
                            "errors of a phase code need a phase code: set phase_code to "
                            f"sz8_64 or random, or {name} to 0",
                        )
                    ]
        span = (stop - start) % 360.0 or 360.0
        if span < step * (1.0 - 1e-9):  # 0.7 to 1.7 deg is one 1-deg beam, not 0.99999...
            return [
                (
                    "parameter 'azimuth_stop_deg'",
                    f"{sector} spans {span:g} deg, less than one beam (beam_spacing_deg = "
                    f"{step:g} deg); widen the sector or space the beams closer",
                )
            ]
        return []

    def setup(self) -> None:
        super().setup()
        self.n_beams = sector_beams(
            self.p["azimuth_start_deg"], self.p["azimuth_stop_deg"], self.p["beam_spacing_deg"]
        )

    def beam_count(self) -> int:
        return self.n_beams

    def _code(self, chunk: Chunk, beam: int) -> np.ndarray:
        """The transmit phases of one beam's pulses: the SZ(8/64) code (repeated every 64
        pulses), or random phases from the beam's own stream (the same whatever the
        chunking)."""
        m = int(self.p["pulses"])
        if self.p["phase_code"] == "sz8_64":
            return np.resize(sz_code(8, 64), m)
        return chunk.rng(beam).uniform(0.0, 2 * np.pi, m)

    def _code_errors(self, chunk: Chunk, beams: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each beam's coded pulses' phase errors (rad) and amplitudes (beam x pulse), from
        the beam's own sub-stream 1 (the same whatever the chunking; the random code's
        stream 0 is not touched)."""
        m, deg = int(self.p["pulses"]), self.p["phase_code_error_deg"]
        drawn = [
            draw_code_errors(chunk.rng(int(b), 1), m, deg, self.p["phase_code_ripple_db"])
            for b in beams
        ]
        return np.stack([d[0] for d in drawn]), np.stack([d[1] for d in drawn])

    def nominal_azimuths(self) -> np.ndarray:
        step = self.p["beam_spacing_deg"]
        return (self.p["azimuth_start_deg"] + step * (np.arange(self.n_beams) + 0.5)) % 360.0

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        az = self.nominal_azimuths()
        truth = inputs.get("truth")
        start, site = site_and_start(inputs, self.p["time_offset_s"])
        moving = self.p["platform"] != "none"
        if truth is not None and self.p["align_to_truth"] and not moving:
            az = _snap(az, truth["azimuth"].values)
        beams = chunk.beams
        prt = self.p["prt_s"]
        if self.p["stagger"] != "uniform":
            # The dwell's pulses alternate T1 and T2 = T1 / ratio apart.
            prt = mean_prt(prt, float(STAGGERS[self.p["stagger"]]))
        dwell = self.p["pulses"] * prt
        ds = beam_dataset(
            self._cf,
            azimuth=az[beams],
            elevation=np.full(beams.size, float(self.p["elevation_deg"])),
            time=start + (beams * dwell * 1e9).astype("timedelta64[ns]"),
            prt=np.full(beams.size, self.p["prt_s"]),
            pulses=int(self.p["pulses"]),
            scan_rate=np.full(beams.size, self.p["beam_spacing_deg"] / dwell),
            sweep_mode=SWEEP_MODE_PPI,
            fixed_angle=float(self.p["elevation_deg"]),
            start=start,
            end=start + seconds(self.n_beams * dwell),
            site=site,
            prt_mode=PRT_MODE_FIXED if self.p["stagger"] == "uniform" else PRT_MODE_STAGGERED,
        )
        if moving:
            ds = carry(ds, self.p, (beams + 0.5) * dwell)
        if self.p["stagger"] != "uniform":
            ds["prt_ratio"] = (
                "beam",
                np.full(beams.size, float(STAGGERS[self.p["stagger"]])),
                {"units": "1", "long_name": "ratio of the PRTs of a staggered scan, T1 / T2"},
            )
        if self.p["phase_code"] != "none":
            ds["transmit_phase"] = (
                ("beam", "pulse"),
                np.stack([self._code(chunk, int(b)) for b in beams]),
                {"units": "radians", "long_name": "transmit phase of each pulse"},
            )
            if self.p["phase_code_error_deg"] > 0 or self.p["phase_code_ripple_db"] > 0:
                error, amplitude = self._code_errors(chunk, beams)
                ds["transmit_phase_error"] = (
                    ("beam", "pulse"),
                    error,
                    {"units": "radians", "long_name": "error of each pulse's transmitted phase"},
                )
                ds["transmit_amplitude"] = (
                    ("beam", "pulse"),
                    amplitude,
                    {"units": "1", "long_name": "voltage amplitude of each pulse over the nominal"},
                )
        return {"beams": ds}


def sector_beams(start_deg: float, stop_deg: float, spacing_deg: float) -> int:
    """Beams of a sector scanned clockwise from ``start_deg`` to ``stop_deg`` (equal ends: the
    full circle)."""
    span = (stop_deg - start_deg) % 360.0 or 360.0
    return max(1, round(span / spacing_deg))


def _nearest(az: np.ndarray, radials: np.ndarray) -> np.ndarray:
    return radials[nearest_radial(az, radials)]


def _snap(az: np.ndarray, radials: np.ndarray) -> np.ndarray:
    """Point beams at truth radials, shifting the whole scan by one common offset first.

    Snapping each beam on its own would break ties differently from beam to beam (1 deg beams
    sit midway between 0.5 deg radials) and make the spacing uneven.
    """
    shift = circular_difference(_nearest(az[:1], radials)[0], az[0], 360.0)
    return _nearest((az + shift) % 360.0, radials)
