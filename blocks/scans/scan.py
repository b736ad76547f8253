"""The scans' bases: what every scan declares (its role, the optional truth, the beams it
emits), and what the scans that dwell the same on every beam share (pulses, PRT, alignment to
the truth, a start after the truth's), and the list of a scan's beams outside a run
(:func:`scan_beams`, for ``pasim pattern --scan``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import cf_attributes

from ..signals import BEAMS, TRUTH


class Scan(Block):
    """Base of the scans: the block that defines a run's beams (``beam_source``), addressed
    by ``--sector`` (role ``scan``), reading the site and start time from the truth when it is
    connected. A subclass implements ``beam_count`` and ``process`` (one chunk's beams, made
    with :func:`~pasim_blocks.scans.beam_geometry.beam_dataset`); ``setup`` leaves the CF attributes
    in ``self._cf``.
    """

    role = "scan"
    beam_source = True

    truth = Input(
        TRUTH, required=False, doc="truth sweep, for site and time (and radials to align to)"
    )
    beams = Output(BEAMS, store="moments", doc="geometry of the beams in the chunk")

    @classmethod
    def given(cls, params: dict[str, Any], name: str) -> Any:
        """A parameter's value in ``params`` (a graph's, at validation: defaults not filled
        in), else its declared default."""
        return params.get(name, cls.params[name].default)

    def setup(self) -> None:
        self._cf = cf_attributes()


class DwellScan(Scan):
    """Base of the scans whose beams all dwell ``pulses`` pulses of ``prt_s`` (PPI, RHI,
    volume), optionally pointed at the truth's radials, starting ``time_offset_s`` after the
    truth's start."""

    pulses = Param(64, type="int", min=2, max=4096, doc="pulses per dwell (M)")
    prt_s = Param(1 / 300, units="s", min=1e-5, max=0.1, doc="pulse repetition time")
    align_to_truth = Param(True, type="bool", doc="point the beams at the nearest truth radial")
    time_offset_s = Param(
        0.0,
        units="s",
        min=0.0,
        max=1e6,
        doc="start of the sweep after the truth's start (a volume sets it for each sweep)",
    )


def scan_beams(graph: Any, name: str) -> list[tuple[float, float]]:
    """(azimuth, elevation) in degrees of every beam of every sweep of the scan block ``name``
    of ``graph`` (a PPI's nominal azimuths, a volume's cuts, an RHI's elevations, a schedule's
    beams), in scan order: each sweep's beams as the block emits them, with no truth to align
    them to."""
    cls = graph.classes[name]
    out: list[tuple[float, float]] = []
    for overrides in cls.scan_sweeps(dict(graph.params[name])):
        scan = cls(name=name, **{**graph.params[name], **overrides})
        n = scan.beam_count()
        beams = scan.process({}, Chunk(beams=np.arange(n), block_name=name))["beams"]
        az, el = beams["azimuth"].values, beams["elevation"].values
        out += [(float(a), float(e)) for a, e in zip(az, el, strict=True)]
    return out
