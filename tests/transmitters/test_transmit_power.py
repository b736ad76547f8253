"""Transmit power as engineers state it: per port, or a total through a power divider
(``transmitter.power_divider``, ``blocks/transmitters/divider.py``).

Reference: the generic radar's SNR at 50 km for a uniform 40 dBZ field, from the radar
equation written out here (Pt G^2 lambda^2 pi^5 |K|^2 Z Omega R / ((4 pi)^3 lambda^4 r^2 L),
Omega the two-way pattern integral, R = 2/3 c tau / 2 for a rectangular pulse and its matched
filter, over the thermal noise k T0 F / tau), with Pt the power per port: ``peak_power_w``
without a divider, ``peak_power_w`` x 10^(-loss/10) / 2 with one. Within 0.1 dB in both.
The convention used is stated in the calibration's attributes (the Pt of the reference) and
in the scorer's rule, which ``pasim score`` prints under its table.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.receivers.filters import MatchedFilter
from pasim_blocks.scans.ppi import PPISector
from pasim_blocks.signals import BOLTZMANN, SPEED_OF_LIGHT, T0_K
from pasim_blocks.transmitters.divider import PowerDivider

from pasim_graph import Chunk, load

from ..conftest import GRAPHS

NO_BEAMS = np.arange(0)
RANGE_M = 50e3
DBZ = 40.0


def uniform_truth():
    az = np.arange(720) * 0.5 + 0.25
    rng = 45e3 + 250.0 * np.arange(41)  # a gate at 50 km, away from the field's edges
    fields = {"DBZH": DBZ, "ZDR": 0.0, "RHOHV": 0.99, "PHIDP": 0.0, "VRADH": 0.0, "WRADH": 1.0}
    return xr.Dataset(
        {
            k: (("radial", "gate"), np.full((az.size, rng.size), v, np.float32))
            for k, v in fields.items()
        },
        coords={"azimuth": ("radial", az), "range": ("gate", rng)},
        attrs={
            "radial_width_deg": 0.5,
            "gate_width_m": 250.0,
            "elevation_deg": 0.5,
            "time_coverage_start": "2016-06-01T15:00:25Z",
            "latitude": 33.0,
            "longitude": -101.0,
            "altitude": 1000.0,
        },
    )


def block(graph, name, **extra):
    return graph.classes[name](name=name, **{**graph.params[name], **extra})


def generic_snr_db(divider: PowerDivider | None) -> tuple[float, dict]:
    """SNR (H) at 50 km through the generic radar's own blocks, expected echo power."""
    graph = load(GRAPHS / "generic_radar.yaml")
    truth = uniform_truth()
    beams_idx = np.arange(2)
    scan = PPISector(name="scan", azimuth_start_deg=100.0, azimuth_stop_deg=102.0, pulses=8)
    beams = scan.process({"truth": truth}, Chunk(beams=beams_idx))["beams"]
    pattern = block(graph, "antenna").process({"beams": beams}, Chunk(beams=beams_idx))["pattern"]
    drive = block(graph, "tx").process({}, Chunk(beams=NO_BEAMS))["pulse"]
    radiated = block(graph, "hpa").process({"pulse_in": drive}, Chunk(beams=NO_BEAMS))["pulse"]
    if divider is not None:
        radiated = divider.process({"pulse_in": radiated}, Chunk(beams=NO_BEAMS))["pulse"]
    response = MatchedFilter(name="mf").process(
        {"pulse": radiated, "reference": drive}, Chunk(beams=NO_BEAMS)
    )["range_response"]
    weather = block(graph, "weather", method="expected")
    out = weather.process(
        {"truth": truth, "beams": beams, "pattern": pattern, "range_response": response},
        Chunk(beams=beams_idx, block_name="weather"),
    )
    rx = block(graph, "receiver").process(
        {"iq_in": out["iq"], "range_response": response}, Chunk(beams=beams_idx, expected=True)
    )
    gate = int(np.argmin(np.abs(out["calibration"]["range"].values - RANGE_M)))
    snr = out["signal_power"][0, gate, 0] / rx["noise_power"][0, gate, 0]
    chunk = Chunk(beams=beams_idx, expected=True)
    moments = block(graph, "ppp").process(
        {
            "iq": rx["iq"],
            "noise_power": rx["noise_power"],
            "calibration": out["calibration"],
            "beams": beams,
            "echo_correlations": out["echo_correlations"],
        },
        chunk,
    )["moments"]
    scores = block(graph, "scorer").process(
        {
            "moments": moments,
            "truth": truth,
            "signal_power": out["signal_power"],
            "noise_power": rx["noise_power"],
            "beams": beams,
        },
        chunk,
    )["scores"]
    ctx = {"graph": graph, "pattern": pattern, "calibration": out["calibration"]}
    return float(10 * np.log10(snr)), ctx | {"rule": scores["scored"].attrs["scored"]}


def radar_equation_snr_db(port_power_w: float, omega_sr: float, graph) -> float:
    """The independent computation (see the module docstring)."""
    lam = SPEED_OF_LIGHT / graph.params["weather"]["frequency_hz"]
    tau = graph.params["tx"]["width_s"]
    gain = 10 ** (graph.params["antenna"]["gain_db"] / 10)
    z = 10 ** (DBZ / 10) * 1e-18
    range_integral = 2 / 3 * SPEED_OF_LIGHT * tau / 2
    signal = (
        port_power_w
        * gain**2
        * lam**2
        * np.pi**5
        * 0.93
        * z
        * omega_sr
        * range_integral
        / ((4 * np.pi) ** 3 * lam**4 * RANGE_M**2)
    )
    noise = BOLTZMANN * T0_K * 10 ** (graph.params["receiver"]["noise_figure_db"] / 10) / tau
    return float(10 * np.log10(signal / noise))


def test_snr_at_50_km_per_port():
    """No divider: peak_power_w (700 kW) is each port's power."""
    snr, ctx = generic_snr_db(None)
    omega = ctx["pattern"].attrs["two_way_solid_angle_sr_H"]
    ref = radar_equation_snr_db(700e3, omega, ctx["graph"])
    assert snr == pytest.approx(ref, abs=0.1)
    attrs = ctx["calibration"].attrs
    assert attrs["transmit_power"].startswith("per port")
    assert attrs["transmit_power_per_port_w"] == pytest.approx(700e3, rel=1e-9)
    assert "transmit power: per port" in ctx["rule"]


def test_snr_at_50_km_divided_total():
    """A 2-way divider with 0.3 dB loss: 700 kW is the transmitter's total, each port gets
    700 kW x 10^(-0.03) / 2; the SNR is 3.31 dB below the per-port convention's."""
    per_port, _ = generic_snr_db(None)
    snr, ctx = generic_snr_db(PowerDivider(name="split", ports=2, loss_db=0.3))
    omega = ctx["pattern"].attrs["two_way_solid_angle_sr_H"]
    ref = radar_equation_snr_db(700e3 * 10 ** (-0.03) / 2, omega, ctx["graph"])
    assert snr == pytest.approx(ref, abs=0.1)
    assert per_port - snr == pytest.approx(10 * np.log10(2) + 0.3, abs=1e-6)
    attrs = ctx["calibration"].attrs
    assert attrs["transmit_power"].startswith("divided total")
    assert "2 ways with 0.3 dB loss" in attrs["transmit_power"]
    assert attrs["transmit_power_per_port_w"] == pytest.approx(700e3 * 10 ** (-0.03) / 2)
    assert "transmit power: divided total" in ctx["rule"]
