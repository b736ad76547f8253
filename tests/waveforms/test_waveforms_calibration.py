"""The radar calibration holds for every waveform: a uniform scene gives back its reflectivity,
and the SNR follows the transmitted energy.

graphs/uniform_ideal.yaml with its rectangular pulse swapped for the section 2.3 waveforms
(3.6 MHz, 50 us), the weather channel at the ``expected`` level (no random draw: the
estimate is the expected power through the radar constant) and thermal noise, run in process.
The weather channel computes the radar constant from the filter's integrated power response
and the receiver the noise from the filter's noise bandwidth, so:

* the reflectivity comes back with bias ~0 dB at every gate whose whole range response lies
  inside the scene (30 gates of 250 m each side of a 50 us pulse), also through a mismatched
  (Taylor-weighted) filter;
* for a point target the matched filter's peak SNR is E / N0: waveforms of the same peak
  power differ by their energy, 10 log10(0.34) = -4.7 dB for the -60 dB Taylor LFM against
  the LFM (computed here from scipy.signal.windows.taylor);
* for weather (a volume target filling the range response) the SNR is E / N0 times the
  integrated range response int |y|^2 dr over the peak, i.e. energy times range resolution:
  the Taylor LFM's wider mainlobe collects more scatterers and gives back part of the energy
  it does not transmit. Both factors are computed here independently (numpy.correlate of the
  waveforms written out here) and their sum is held against the channel's SNR.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal.windows as windows

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import validate
from pasim_graph.graphfile import parse

from ..conftest import GRAPHS

B_HZ, T_S, FS = 3.6e6, 50e-6, 7.2e6
RECT = "tx:       {type: waveform.rectangular, params: {width_s: 1.6e-06}}"
WAVEFORMS = {
    "rectangular": RECT,
    "lfm": "tx: {type: waveform.lfm}",
    "taylor_lfm": "tx: {type: waveform.lfm, params: {window: taylor, taylor_sidelobe_db: -60.0}}",
    "nlfm": "tx: {type: waveform.nlfm, params: {design: optimised}}",
    "nlfm_gaussian": "tx: {type: waveform.nlfm}",
    "lfm_mismatched": "tx: {type: waveform.lfm}",
}
FILTERS = {"lfm_mismatched": "mf: {type: filter.mismatched, params: {taylor_sidelobe_db: -40.0}}"}
GATES = 100  # 25 km from 20 km; gates 30..69 see the whole 50 us response


def run(name: str):
    text = (GRAPHS / "uniform_ideal.yaml").read_text()
    assert RECT in text
    text = text.replace(RECT, WAVEFORMS[name])
    if name in FILTERS:
        text = text.replace("mf:       {type: filter.matched}", FILTERS[name])
    text = text.replace("method: covariance", "method: expected")
    text = text.replace("snr_db: 20.0", "snr_db: null")  # thermal noise
    text = text.replace("azimuth_stop_deg: 40.0", "azimuth_stop_deg: 2.0")
    graph = validate(parse(text))
    assert graph.value("scene", "gates") == GATES
    return LocalExecutor(graph, RunOptions()).run()


@pytest.fixture(scope="module")
def runs():
    return {name: run(name) for name in WAVEFORMS}


INNER = slice(31, 69)


@pytest.mark.parametrize("name", list(WAVEFORMS))
def test_uniform_scene_gives_back_its_reflectivity(runs, name: str) -> None:
    ds = runs[name]
    err = (ds["DBZH"] - ds["truth_DBZH"]).values[:, INNER]
    assert np.all(np.isfinite(err))
    assert np.max(np.abs(err)) < 0.01, f"{name}: bias {err.mean():.4f} dB"


def lfm(window: np.ndarray | None = None) -> np.ndarray:
    n = round(T_S * FS)
    t = (np.arange(n) - (n - 1) / 2) / FS
    s = np.exp(1j * np.pi * B_HZ / T_S * t**2)
    return s if window is None else s * window / window.max()


def integrated_response(s: np.ndarray) -> float:
    """int |y|^2 dr (m) of the matched filter scaled to peak 1, y = (s (x) s) / E."""
    y = np.correlate(s, s, mode="full") / np.sum(np.abs(s) ** 2)
    return float(np.sum(np.abs(y) ** 2) * 299_792_458.0 / (2 * FS))


def test_snr_follows_energy_and_range_resolution(runs) -> None:
    taylor = windows.taylor(round(T_S * FS), nbar=10, sll=60)
    s_lfm, s_tay = lfm(), lfm(taylor)
    energy_db = 10 * np.log10(np.mean(np.abs(s_tay) ** 2) / np.mean(np.abs(s_lfm) ** 2))
    assert energy_db == pytest.approx(10 * np.log10(0.342), abs=0.05)
    resolution_db = 10 * np.log10(integrated_response(s_tay) / integrated_response(s_lfm))
    snr = {k: float(runs[k]["SNRH"].values[:, INNER].mean()) for k in ("lfm", "taylor_lfm")}
    measured = snr["taylor_lfm"] - snr["lfm"]
    assert measured == pytest.approx(energy_db + resolution_db, abs=0.02)
    assert measured < 0  # the energy lost outweighs the wider mainlobe


def test_point_target_snr_is_the_energy_ratio() -> None:
    """Peak SNR of a point target through each filter: max|y|^2 / B_noise (N0 = 1, unit peak
    power), which is E / N0 for a matched filter: the Taylor LFM's is its efficiency times
    the LFM's, and the NLFM's its efficiency times the LFM's."""
    from pasim_blocks.receivers.filters import MatchedFilter
    from pasim_blocks.waveforms.pulses import LinearFM, NonlinearFM

    from pasim_graph import Chunk

    def peak_snr(block) -> tuple[float, float]:
        pulse = block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["pulse"]
        rr = MatchedFilter(name="mf").process(
            {"pulse": pulse, "reference": pulse}, Chunk(beams=np.arange(0))
        )["range_response"]
        env = pulse["envelope"].values
        efficiency = float(np.mean(np.abs(env) ** 2))
        return float(rr["power_weight"].max()) / rr.attrs["noise_bandwidth_hz"], efficiency

    ref, _ = peak_snr(LinearFM(name="tx"))
    assert ref == pytest.approx(T_S, rel=1e-9)  # E / N0 = T for unit peak power
    for block in (
        LinearFM(name="tx", window="taylor"),
        NonlinearFM(name="tx", design="optimised"),
        NonlinearFM(name="tx"),
    ):
        snr, eff = peak_snr(block)
        assert 10 * np.log10(snr / ref) == pytest.approx(10 * np.log10(eff), abs=1e-9)
