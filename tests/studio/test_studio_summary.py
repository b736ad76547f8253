"""The studio's system summary: the radar's key quantities derived from its graph.

Checked against the paper's Table 4 for the generic radar (2800 MHz, PRF 300 Hz) through
textbook relations written out here independently of the module (Doviak and Zrnic), and
the sensitivity against the weather radar equation evaluated in decibels term by term.
"""

from __future__ import annotations

import math

import pytest

from pasim_graph.graphfile import read
from pasim_graph.studio.summary import key_values, quantity, system_summary

from ..conftest import GRAPHS
from .test_studio_http import Client

C = 299_792_458.0


def rows(path):
    return {r["key"]: r for r in system_summary(read(path))["rows"]}


def test_generic_radar_summary_matches_table_4():
    """Table 4 of the paper: 2800 MHz, PRF 300 Hz, 1.0 deg, 1.6 us. The Nyquist velocity
    lambda * PRF / 4 and the unambiguous range c / (2 PRF) follow (Doviak and Zrnic
    eqs. 3.14 and 3.5): 8.0 m/s and 500 km."""
    r = rows(GRAPHS / "generic_radar.yaml")
    assert r["prf"]["value"] == pytest.approx(300.0)
    assert r["prf"]["text"] == "300 Hz"
    lam = C / 2800e6
    assert r["nyquist_velocity"]["value"] == pytest.approx(lam * 300 / 4)
    assert r["nyquist_velocity"]["text"] == "8.0 m/s"
    assert r["unambiguous_range"]["value"] == pytest.approx(C / (2 * 300))
    assert r["unambiguous_range"]["text"] == "500 km"
    assert r["beamwidth"]["value"] == 1.0
    assert r["frequency"]["text"] == "2.8 GHz"
    assert r["pulse_width"]["text"] == "1.6 us"
    assert r["range_resolution"]["value"] == pytest.approx(C * 1.6e-6 / 2)  # 240 m
    assert r["transmit_mode"]["value"] == "shv"
    assert "scan.prt_s" in r["prf"]["from"]


def test_sensitivity_is_the_radar_equation_in_decibels():
    """Z_min(50 km) in dBZ from the weather radar equation written in dB, term by term:
    noise k T0 F / tau (dBW), minus the radar constant pi^3 Pt G^2 theta^2 c tau |K|^2 /
    (1024 ln2 lambda^2) (dB), plus 20 log10 r, plus 180 (m^6 m^-3 to mm^6 m^-3)."""
    r = rows(GRAPHS / "generic_radar.yaml")
    pt, g_db, theta, tau, f, nf_db = 700e3, 45.5, math.radians(1.0), 1.6e-6, 2.8e9, 2.7
    lam = C / f
    noise_dbw = 10 * math.log10(1.380649e-23 * 290) + nf_db - 10 * math.log10(tau)
    constant_db = (
        10 * math.log10(math.pi**3 * pt * theta**2 * C * tau * 0.93)
        + 2 * g_db
        - 10 * math.log10(1024 * math.log(2) * lam**2)
    )
    expected = noise_dbw - constant_db + 20 * math.log10(50e3) + 180
    assert r["sensitivity_50km"]["value"] == pytest.approx(expected, abs=1e-9)
    assert r["sensitivity_50km"]["units"] == "dBZ"


def test_a_swept_pulse_resolves_by_its_bandwidth():
    """An LFM pulse: range resolution c / (2 B). Its matched filter keeps the pulse's
    energy Pt tau (compression gain tau B) over a noise bandwidth B, against 1 / tau_r for
    the generic radar's rectangular pulse: the sensitivity changes by
    10 log10(B tau_r) - 10 log10(E_lfm / E_r), the rest of the two graphs being equal."""
    spec = read(GRAPHS / "waveform_lfm.yaml")
    generic = read(GRAPHS / "generic_radar.yaml")
    same = {n: b for n, b in spec.blocks.items() if n not in ("tx", "weather")}
    assert same == {n: b for n, b in generic.blocks.items() if n not in ("tx", "weather")}
    r = {x["key"]: x for x in system_summary(spec)["rows"]}
    g = {x["key"]: x for x in system_summary(generic)["rows"]}
    tx, weather = spec.blocks["tx"].params, spec.blocks["weather"].params
    band, width, power = tx["bandwidth_hz"], tx["width_s"], weather["peak_power_w"]
    tau_r = generic.blocks["tx"].params["width_s"]
    power_r = generic.blocks["weather"].params["peak_power_w"]
    assert r["range_resolution"]["value"] == pytest.approx(C / (2 * band))
    expected = 10 * math.log10(band * tau_r) - 10 * math.log10(power * width / (power_r * tau_r))
    change = r["sensitivity_50km"]["value"] - g["sensitivity_50km"]["value"]
    assert change == pytest.approx(expected, abs=1e-9)


def test_an_array_without_a_beamwidth_says_what_is_missing():
    out = system_summary(read(GRAPHS / "cppar10_radar.yaml"))
    keys = {x["key"] for x in out["rows"]}
    assert "beamwidth" not in keys and "sensitivity_50km" not in keys
    assert any("beamwidth_deg" in m for m in out["missing"])
    assert {"prf", "nyquist_velocity", "unambiguous_range"} <= keys


def test_key_values_carry_units():
    keys = key_values(read(GRAPHS / "generic_radar.yaml"))
    assert [k["text"] for k in keys["weather"]] == ["2.8 GHz", "700 kW"]
    assert keys["tx"] == [{"name": "width_s", "text": "1.6 us"}]
    assert keys["scan"][0] == {"name": "prt_s", "text": "3.33 ms"}


@pytest.mark.parametrize(
    "value, units, text",
    [
        (2.8e9, "Hz", "2.8 GHz"),
        (1.6e-6, "s", "1.6 us"),
        (7e5, "W", "700 kW"),
        (45.5, "dB", "45.5 dB"),
    ],
)
def test_quantities_take_si_prefixes(value, units, text):
    assert quantity(value, units) == text


def test_the_page_gets_the_summary(tmp_path):
    import shutil

    from pasim_graph.studio.server import StudioServer

    shutil.copytree(GRAPHS, tmp_path / "graphs")
    server = StudioServer(tmp_path / "graphs", 0, token="t0ken-for-summary-test")
    server.serve_in_thread()
    try:
        c = Client(server.port, token="t0ken-for-summary-test")
        status, g = c.get("/api/graph?path=generic_radar.yaml")
        assert status == 200
        texts = {r["label"]: r["text"] for r in g["validation"]["summary"]["rows"]}
        assert texts["PRF"] == "300 Hz" and texts["Nyquist velocity"] == "8.0 m/s"
        doc = g["doc"]
        doc["blocks"]["scan"]["params"]["prt_s"] = "0.001"
        status, v = c.post("/api/validate", {"path": "generic_radar.yaml", "doc": doc})
        texts = {r["label"]: r["text"] for r in v["summary"]["rows"]}
        assert texts["PRF"] == "1 kHz" and texts["Unambiguous range"] == "150 km"
    finally:
        server.close()
