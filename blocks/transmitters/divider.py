"""A transmit power divider: one transmitter's peak power split between the antenna's ports.

The weather channel's ``peak_power_w`` is the peak power of the envelope's amplitude 1 at
*each* port: a graph without this block transmits ``peak_power_w`` on H and the same again on
V (simultaneous transmission), twice the power a single transmitter of that rating radiates.
A radar whose one transmitter feeds both ports through a divider (the WSR-88D's dual-pol
design) is stated as the total: put this block after the amplifier (``hpa.pulse ->
split.pulse_in``, ``split.pulse -> mf.pulse``) and ``peak_power_w`` then means the
transmitter's total; each port radiates total x 10^(-loss_db / 10) / ports.

It scales the radiated envelope's amplitude by sqrt(10^(-loss_db / 10) / ports): the echo
power and the range weighting the calibration integrates scale alike, so reflectivity stays
calibrated and the SNR falls by 10 log10(ports) + loss_db (3.01 dB + the loss for two ports).
The receive filter keeps its reference (the undivided waveform), so its noise bandwidth is
unchanged. Deterministic.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Block, Chunk, Input, Output, Param

from ..signals import PULSE


def port_fraction(ports: int, loss_db: float) -> float:
    """The fraction of the transmitter's power each port receives."""
    return float(10 ** (-loss_db / 10) / ports)


class PowerDivider(Block):
    """Splits the transmitter's peak power between the ports, with the divider's loss."""

    pulse_in = Input(PULSE, doc="the amplifier's output, 1 = the transmitter's total peak power")
    pulse = Output(PULSE, doc="the envelope at one port, 1 = the total peak power")

    ports = Param(2, type="int", min=1, max=100_000, doc="ports the power is divided between")
    loss_db = Param(
        0.0, units="dB", min=0.0, max=20.0, doc="divider insertion loss beyond the ideal split"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        ds = inputs["pulse_in"]
        scale = np.sqrt(port_fraction(self.p["ports"], self.p["loss_db"]))
        out = ds.copy(data={"envelope": ds["envelope"].values * scale})
        # Stamped on the pulse so that the calibration (and the score) can say the
        # convention: peak_power_w is then the transmitter's total, divided.
        out.attrs["power_divider_ports"] = int(self.p["ports"])
        out.attrs["power_divider_loss_db"] = float(self.p["loss_db"])
        return {"pulse": out}
