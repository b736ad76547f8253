"""An example plugin: one block, registered through the ``pasim_graph.blocks`` entry points."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param, PortType

# The same port type the built-in weather channel and receiver use: a plugin block can sit
# between them because its ports agree in kind, dtype, dimensions and units.
IQ = PortType("iq", "complex64", ("beam", "range", "pulse", "polarization"), "sqrt(W)")


class Attenuator(Block):
    """A fixed RF attenuator (e.g. a lossy radome) on both polarisations."""

    iq_in = Input(IQ, doc="voltages in")
    iq = Output(IQ, doc="voltages out")
    loss_db = Param(3.0, units="dB", min=0.0, max=100.0, doc="one-way power loss")

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        return {"iq": inputs["iq_in"] * np.float32(10 ** (-self.p["loss_db"] / 20))}
