"""``pasim spectrum`` and the amplifiers' rise and fall edges (``blocks/commands/spectrum.py``,
``blocks/transmitters/radiated.py``, ``emission.py``, ``amplifiers.py``).

What each test compares against:

* the -40 dB bandwidths of the rectangular 1.6 us pulse (with linear edges), the Taylor LFM
  through the saturated Saleh amplifier and the optimised NLFM: an independent computation
  (``tests/reference/spectrum.py``: the DTFT summed directly, crossings refined by Brent's
  method; the trapezoid's closed-form spectrum; the Taylor LFM and the Saleh amplifier
  rebuilt from their definitions), within 5 %;
* the edge gate: its definition (10-90 % of the amplitude in the stated time);
* the criteria: the theory the RSEC constants rest on (64 / t is the rectangle's -40 dB
  bandwidth; K / sqrt(t_r t) the trapezoid's asymptote), and the mask's formula;
* pass and fail: the rectangular pulse with ideal edges fails category D's 40 dB per decade
  roll-off (a sinc^2 falls 20 dB per decade), the NLFM passes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from pasim_blocks.transmitters.amplifiers import RAMP_10_90, SalehAmplifier, edge_gate
from pasim_blocks.transmitters.emission import (
    mask_db,
    rise_fall_times,
    rsec_criteria,
)
from pasim_blocks.transmitters.radiated import analyse
from pasim_blocks.waveforms.pulses import pulse_dataset

from pasim_graph import Chunk, load

from ..conftest import GRAPHS, pasim_result
from ..reference.spectrum import (
    bandwidth_40_dtft,
    taylor_lfm_through_saleh,
    trapezoid_bandwidth_40,
)

RISE_S = 100e-9


@pytest.fixture(scope="module")
def spectra():
    rect = load(
        GRAPHS / "generic_radar.yaml", {"hpa.rise_time_s": RISE_S, "hpa.fall_time_s": RISE_S}
    )
    return {
        "rect": analyse(rect),
        "rect_hard": analyse(load(GRAPHS / "generic_radar.yaml")),
        "taylor": analyse(load(GRAPHS / "waveform_taylor_lfm.yaml")),
        "nlfm": analyse(load(GRAPHS / "waveform_nlfm.yaml")),
    }


@pytest.mark.parametrize("name", ["rect", "taylor", "nlfm"])
def test_bandwidth_40_against_direct_dtft(spectra, name: str) -> None:
    """The command's -40 dB bandwidth (zero-padded FFT, interpolated) against the DTFT of the
    same radiated pulse summed directly with Brent-refined crossings: within 5 %."""
    s = spectra[name]
    env = s.radiated["envelope"].values
    ref = bandwidth_40_dtft(env, s.metrics["analysis_sample_rate_hz"])
    assert s.metrics["bandwidth_40_hz"] == pytest.approx(ref, rel=0.05)


def test_rect_bandwidth_against_the_trapezoid_closed_form(spectra) -> None:
    """The rectangular 1.6 us pulse with 100 ns (10-90 %) linear edges: the continuous
    trapezoid's -40 dB bandwidth (closed form), within 5 %."""
    m = spectra["rect"].metrics
    ref = trapezoid_bandwidth_40(1.6e-6, RISE_S / RAMP_10_90)
    assert m["bandwidth_40_hz"] == pytest.approx(ref, rel=0.05)
    assert m["rise_time_s"] == pytest.approx(RISE_S, rel=0.05)


def test_taylor_lfm_through_saleh_rebuilt_independently(spectra) -> None:
    """The Taylor LFM through the saturated Saleh amplifier, rebuilt from scipy's window and
    the paper's equations at the command's sample rate: its -40 dB bandwidth within 5 %."""
    m = spectra["taylor"].metrics
    fs = m["analysis_sample_rate_hz"]
    ref = bandwidth_40_dtft(taylor_lfm_through_saleh(3.6e6, 50e-6, fs), fs)
    assert m["bandwidth_40_hz"] == pytest.approx(ref, rel=0.05)
    # The amplifier widens the spectrum: saturation flattens the Taylor taper.
    assert m["bandwidth_40_hz"] > m["bandwidth_40_drive_hz"]


def test_rectangular_fails_and_nlfm_passes(spectra) -> None:
    """Category D (40 dB per decade): the ideal-edged rectangle's sinc^2 falls only 20 dB per
    decade, so it fails; the NLFM (optimised law, light taper) passes with margin."""
    hard, nlfm = spectra["rect_hard"].metrics, spectra["nlfm"].metrics
    assert not hard["passes"] and hard["margin_db"] < -5
    assert nlfm["passes"] and nlfm["margin_db"] > 10
    # The ideal rectangle's -40 dB bandwidth is the criteria's 64 / t cap (200 / (pi t)).
    assert hard["bandwidth_40_hz"] == pytest.approx(200 / (np.pi * 1.6e-6), rel=0.03)
    assert hard["bandwidth_40_allowed_hz"] == pytest.approx(64e6 / 1.6, rel=1e-3)


def test_edge_gate_rise_time_is_the_10_90_time() -> None:
    """A constant envelope through the gate rises from 10 % to 90 % in rise_s (and falls in
    fall_s), measured by interpolation at a rate fine against the ramps."""
    fs = 2e9
    gate = edge_gate(round(2e-6 * fs), fs, 100e-9, 250e-9)
    rise, fall = rise_fall_times(gate, fs)
    assert rise == pytest.approx(100e-9, rel=0.01)
    assert fall == pytest.approx(250e-9, rel=0.01)
    np.testing.assert_array_equal(edge_gate(10, 1e6, 0.0, 0.0), np.ones(10))


def test_amplifier_default_keeps_the_envelope_and_edges_too_long_are_refused() -> None:
    """Zero rise and fall (the default) leave the Saleh output as before; edges longer than
    the pulse are a clear error naming the block."""
    drive = pulse_dataset(np.ones(32, complex), 20e6)
    chunk = Chunk(beams=np.arange(0))
    plain = SalehAmplifier(name="hpa").process({"pulse_in": drive}, chunk)["pulse"]
    edged = SalehAmplifier(name="hpa", rise_time_s=0.0, fall_time_s=0.0).process(
        {"pulse_in": drive}, chunk
    )["pulse"]
    np.testing.assert_array_equal(plain["envelope"].values, edged["envelope"].values)
    with pytest.raises(ValueError, match=r"block 'hpa'.*longer than the"):
        SalehAmplifier(name="hpa", rise_time_s=1e-6, fall_time_s=1e-6).process(
            {"pulse_in": drive}, chunk
        )


def test_criteria_rest_on_the_rectangle_and_the_trapezoid() -> None:
    """64 / t is the ideal rectangle's -40 dB bandwidth within 1 % (200 / pi); K / sqrt(t_r t)
    with K = 6.2 lies within 10 % of the trapezoid's asymptote 20 / (pi sqrt(t t_ramp)) at the
    10-90 % ramp, and the FM form adds twice the chirp."""
    assert 64 / 1.6e-6 == pytest.approx(200 / (np.pi * 1.6e-6), rel=0.01)
    c = rsec_criteria("D", 1.6e-6, 0.1e-6, 700e3)
    asymptote = 20 / (np.pi * np.sqrt(1.6e-6 * 0.1e-6 / RAMP_10_90))
    assert c.k == 6.2 and c.bandwidth_40_hz == pytest.approx(asymptote, rel=0.10)
    fm = rsec_criteria("D", 50e-6, 1e-6, 22.4e3, chirp_hz=3.6e6)
    assert fm.bandwidth_40_hz == pytest.approx(7.6e6 / np.sqrt(50) + 7.2e6, rel=1e-12)
    with pytest.raises(ValueError, match="rise time"):
        rsec_criteria("D", 50e-6, 0.0, 22.4e3, chirp_hz=3.6e6)


def test_mask_shape() -> None:
    """0 dB inside B(-40)/2, -40 dB at its edge, then the slope per decade to the spurious
    level (category D: 40 dB per decade, 60 dB)."""
    c = rsec_criteria("D", 1.6e-6, 0.1e-6, 700e3)
    half = c.bandwidth_40_hz / 2
    f = np.array([0.0, 0.99 * half, 1.0001 * half, 2 * half, 10 * half, -10 * half])
    m = mask_db(f, c)
    assert m[0] == 0 and m[1] == 0
    assert m[2] == pytest.approx(-40, abs=0.01)
    assert m[3] == pytest.approx(-40 - 40 * np.log10(2), abs=1e-9)
    assert m[4] == -60 and m[5] == -60


def test_command_line_json_plot_and_errors(tmp_path, capsys) -> None:
    png = tmp_path / "spectrum.png"
    res = pasim_result(
        capsys, "spectrum", str(GRAPHS / "waveform_nlfm.yaml"), "--json", "--plot", str(png)
    )
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert out["passes"] is True and out["category"] == "D"
    assert isinstance(out["margin_db"], float)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = pasim_result(
        capsys, "spectrum", str(GRAPHS / "waveform_nlfm.yaml"), "--peak-power-w", "-3"
    )
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "--peak-power-w" in bad.stderr
    long_edges = pasim_result(
        capsys,
        "spectrum",
        str(GRAPHS / "generic_radar.yaml"),
        "--set",
        "hpa.rise_time_s=1e-6",
        "--set",
        "hpa.fall_time_s=1e-6",
    )
    assert long_edges.returncode == 2 and "Traceback" not in long_edges.stderr
    assert "hpa" in long_edges.stderr and "rise_time_s" in long_edges.stderr
