"""The Doppler half of a NEXRAD split cut: the surveillance scan's beams with a short PRT."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import BEAMS


class DopplerCut(Block):
    """The same beams as the scan (azimuths, elevation, times), dwelling ``pulses`` pulses of
    a short ``prt_s``: the Doppler cut of a split cut (the WSR-88D's lowest elevations scan
    each angle twice, a long-PRT surveillance cut for reflectivity and range, and a short-PRT
    Doppler cut for velocity and width). A second weather channel fed these beams draws the
    Doppler cut's echoes, range folding included; ``processor.split_cut`` merges the two."""

    beams_in = Input(BEAMS, doc="the surveillance scan's beams")
    beams = Output(BEAMS, doc="the Doppler cut's beams")

    prt_s = Param(1e-3, units="s", min=1e-5, max=0.1, doc="pulse repetition time of the cut")
    pulses = Param(64, type="int", min=2, max=4096, doc="pulses per dwell of the cut (M)")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        beams = inputs["beams_in"].copy()
        n = beams.sizes["beam"]
        old_dwell = float(beams["prt"].values[0]) * int(beams["pulses"].values)
        beams["prt"] = ("beam", np.full(n, float(self.p["prt_s"])), dict(beams["prt"].attrs))
        beams["pulses"] = ((), int(self.p["pulses"]), dict(beams["pulses"].attrs))
        for name in ("prt_ratio", "transmit_phase", "transmit_phase_error", "transmit_amplitude"):
            if name in beams:
                beams = beams.drop_vars(name)
        if "scan_rate" in beams:
            dwell = float(self.p["prt_s"]) * int(self.p["pulses"])
            beams["scan_rate"] = beams["scan_rate"] * (old_dwell / dwell)
        return {"beams": beams}
