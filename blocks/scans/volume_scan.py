"""A volume scan: PPI cuts one after another (a NEXRAD VCP, or any list of cuts)."""

from __future__ import annotations

from typing import Any

from pasim_graph import Param
from pasim_graph.scores import mean_prt

from ..timing import STAGGERS
from .ppi import PPISector, sector_beams
from .vcp import PRESETS, Cut, parse_cuts, preset_key


class VolumeScan(PPISector):
    """A volume: PPI cuts, each an elevation with its own PRT, pulses and optionally its own
    azimuth sector (else the scan's ``azimuth_start_deg`` to ``azimuth_stop_deg``), scanned
    one after the other. Each cut is one sweep of the run (``sweep_0`` ... in the store), the
    graph run with this block's ``elevation_deg``, ``prt_s``, ``pulses``, sector and
    ``time_offset_s`` set to the cut's (the values given for those in the graph are not used).

    ``preset`` names a NEXRAD volume coverage pattern (``vcp212``, ``vcp215``: elevations from
    the WSR-88D's published tables, PRTs and pulses approximate, see
    :mod:`pasim_blocks.scans.vcp`); with ``preset`` empty, ``cuts`` lists them as
    ``ELEVATION_DEG PRT_S PULSES [AZ0:AZ1]`` separated by ``;``. A split cut is two cuts at
    the same elevation (long PRT, then short). Sweeps follow each other in time, each
    starting when the one before has dwelt on all its beams.
    """

    preset = Param(
        "vcp212",
        type="str",
        doc="named volume coverage pattern (vcp212, vcp215); empty: the cuts given in 'cuts'",
    )
    cuts = Param(
        "",
        type="str",
        doc="cuts 'ELEVATION_DEG PRT_S PULSES [AZ0:AZ1]' separated by ';' (with preset '')",
    )

    @classmethod
    def volume_cuts(cls, params: dict[str, Any]) -> tuple[list[Cut], list[tuple[str, str]]]:
        """The volume's cuts and the problems with ``preset`` and ``cuts``."""
        preset = cls.given(params, "preset") or ""
        text = cls.given(params, "cuts") or ""
        known = ", ".join(PRESETS)
        if preset.strip() and text.strip():
            return [], [
                (
                    "parameter 'cuts'",
                    f"both preset {preset!r} and cuts are given: set preset to '' to scan "
                    "the cuts, or leave cuts empty",
                )
            ]
        if preset.strip():
            if preset_key(preset) not in PRESETS:
                return [], [
                    (
                        "parameter 'preset'",
                        f"unknown volume coverage pattern {preset!r}; known presets: {known} "
                        "(or preset '' and your own 'cuts')",
                    )
                ]
            return list(PRESETS[preset_key(preset)]), []
        cuts, problems = parse_cuts(text)
        return cuts, [("parameter 'cuts'", p) for p in problems]

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        cuts, problems = cls.volume_cuts(params)
        if problems:
            return problems
        start = cls.given(params, "azimuth_start_deg")
        stop = cls.given(params, "azimuth_stop_deg")
        span = (stop - start) % 360.0 or 360.0
        out = []
        for n, cut in enumerate(cuts, start=1):
            sweep = {**params, **cls.cut_params(params, cut)}
            out += super().check_config(sweep, connected)
            if cut.sector is None or span == 360.0:
                continue
            # The truth is read for the scan's sector (plus a margin): a cut's own sector must
            # lie inside it.
            offset = (cut.sector[0] - start) % 360.0
            width = (cut.sector[1] - cut.sector[0]) % 360.0 or 360.0
            if offset + width > span + 1e-9:
                out.append(
                    (
                        "parameter 'cuts'",
                        f"cut {n}'s sector {cut.sector[0]:g}:{cut.sector[1]:g} is outside the "
                        f"scan's sector {start:g} to {stop:g} deg (the truth is read for that "
                        "sector): widen azimuth_start_deg/azimuth_stop_deg or the cut's sector",
                    )
                )
        return sorted(set(out))

    @classmethod
    def cut_params(cls, params: dict[str, Any], cut: Cut) -> dict[str, Any]:
        """This block's parameters for ``cut`` (its time offset excepted)."""
        out: dict[str, Any] = {
            "elevation_deg": cut.elevation_deg,
            "prt_s": cut.prt_s,
            "pulses": cut.pulses,
        }
        if cut.sector is not None:
            out["azimuth_start_deg"], out["azimuth_stop_deg"] = cut.sector
        return out

    @classmethod
    def scan_sweeps(cls, params: dict[str, Any]) -> list[dict[str, Any]]:
        cuts, problems = cls.volume_cuts(params)
        if problems:
            raise ValueError("; ".join(f"{item}: {message}" for item, message in problems))
        out, offset = [], float(cls.given(params, "time_offset_s"))
        for cut in cuts:
            sweep = {**cls.cut_params(params, cut), "time_offset_s": offset}
            values = {**params, **sweep}
            n = sector_beams(
                cls.given(values, "azimuth_start_deg"),
                cls.given(values, "azimuth_stop_deg"),
                cls.given(values, "beam_spacing_deg"),
            )
            prt = cut.prt_s
            if cls.given(values, "stagger") != "uniform":
                prt = mean_prt(prt, float(STAGGERS[cls.given(values, "stagger")]))
            offset += n * cut.pulses * prt
            out.append(sweep)
        return out
