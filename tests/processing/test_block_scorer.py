"""Tests of the scorer block (``blocks/scorer.py``) and of ``pasim_graph.store.summarize``.

What each test compares against:

* circular differences: hand-worked examples (estimate minus truth, wrapped into
  [-P/2, P/2): phi_DP 1 deg estimated as 359 deg is an error of -2 deg; velocity on the
  circle of twice the Nyquist velocity);
* errors and mask: errors injected by hand into estimates built from a hand-made truth
  (the scorer must give back exactly the injected error where the documented rule holds:
  truth DBZH >= min_reflectivity_dbz, expected SNR >= min_snr_db, estimate and truth of
  that moment finite; NaN elsewhere), with the truth radial nearest each beam across north;
* requirements: the paper's Table 3 (Z 1/1 dB, v 1/1 m/s, width 1/1 m/s, ZDR 0.1/0.2 dB,
  rho_hv 0.005/0.01, phi_DP 1/2 deg);
* ``summarize``: bias, standard deviation (ddof = 1) and count computed with numpy here.

Everything is deterministic; tolerances are float32 rounding (1e-4 on values up to 360).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.angles import circular_difference
from pasim_blocks.processing.scorer import NexradScorer
from pasim_blocks.scans.ppi import PPISector

from pasim_graph import Chunk
from pasim_graph.store import summarize

# Paper Table 3: NEXRAD data-quality requirements (bias, standard deviation).
TABLE_3 = {
    "DBZH": (1.0, 1.0),
    "VRADH": (1.0, 1.0),
    "WRADH": (1.0, 1.0),
    "ZDR": (0.1, 0.2),
    "RHOHV": (0.005, 0.01),
    "PHIDP": (1.0, 2.0),
}
MOMENTS = tuple(TABLE_3)
N_BEAMS, N_GATES, N_TRUTH_GATES = 3, 6, 8
RADIAL_AZ = np.array([180.0, 358.9, 0.1, 1.2, 90.0])  # deliberately unordered
NEAREST = np.array([1, 2, 3])  # beams at 359, 0 and 1 deg (see beams())
NYQUIST = np.array([8.0, 8.0, 10.0])  # per beam
NOISE = np.array([1e-12, 5e-12])
# Gate roles (same in every beam): 0 plain; 1 truth DBZH 9.5 (below 10); 2 truth DBZH exactly
# 10 (scored: >=); 3 expected SNR 9.5 dB; 4 VRADH estimate NaN; 5 ZDR truth NaN.
SNR_DB = np.array([30.0, 30.0, 30.0, 9.5, 25.0, 12.0])


def test_circular_difference_examples() -> None:
    """Estimate minus truth on the circle, in [-P/2, P/2)."""
    assert circular_difference(np.array(359.0), np.array(1.0), 360.0) == pytest.approx(-2.0)
    assert circular_difference(np.array(1.0), np.array(359.0), 360.0) == pytest.approx(2.0)
    assert circular_difference(np.array(10.0), np.array(350.0), 360.0) == pytest.approx(20.0)
    assert circular_difference(np.array(180.0), np.array(0.0), 360.0) == pytest.approx(-180.0)
    assert circular_difference(np.array(30.0), np.array(20.0), 360.0) == pytest.approx(10.0)
    # Velocity, Nyquist 8 m/s: -7.5 estimated for a truth of 7.5 is an alias 1 m/s beyond.
    assert circular_difference(np.array(-7.5), np.array(7.5), 16.0) == pytest.approx(1.0)
    assert circular_difference(np.array(7.5), np.array(-7.5), 16.0) == pytest.approx(-1.0)
    # Per-beam periods broadcast.
    out = circular_difference(
        np.array([[7.0], [9.0]]), np.array([[-7.0], [-9.0]]), 2 * np.array([[8.0], [10.0]])
    )
    np.testing.assert_allclose(out, [[-2.0], [-2.0]])


def beams() -> xr.Dataset:
    scan = PPISector(
        name="scan",
        azimuth_start_deg=358.5,
        azimuth_stop_deg=1.5,
        beam_spacing_deg=1.0,
        align_to_truth=False,
    )
    return scan.process({}, Chunk(beams=np.arange(N_BEAMS)))["beams"]


def scene(seed: int = 1, biases: dict[str, float] | None = None):
    """Truth, estimates with injected errors, and the other scorer inputs."""
    rng = np.random.default_rng(seed)
    shape = (RADIAL_AZ.size, N_TRUTH_GATES)
    truth = {
        "DBZH": rng.uniform(20, 50, shape),
        "VRADH": rng.uniform(-7.9, 7.9, shape),
        "WRADH": rng.uniform(0.5, 5, shape),
        "ZDR": rng.uniform(-1, 3, shape),
        "RHOHV": rng.uniform(0.9, 0.999, shape),
        "PHIDP": rng.uniform(350, 370, shape) % 360,  # straddles 0/360
    }
    truth["DBZH"][NEAREST, 1] = 9.5
    truth["DBZH"][NEAREST, 2] = 10.0
    truth["ZDR"][NEAREST, 5] = np.nan
    spread = {"DBZH": 0.5, "VRADH": 1.0, "WRADH": 0.5, "ZDR": 0.15, "RHOHV": 0.006, "PHIDP": 1.5}
    biases = biases or {}
    err = {k: rng.normal(biases.get(k, 0.0), spread[k], (N_BEAMS, N_GATES)) for k in MOMENTS}
    # Pairs across the folds: phi_DP 359 -> 1 (+2 deg) and 1 -> 359 (-2 deg); velocity 7.5
    # + 1 m/s, which folds to -7.5 at Nyquist 8 m/s (beams 0 and 1) but not at 10 (beam 2).
    truth["PHIDP"][NEAREST, 0], err["PHIDP"][:, 0] = 359.0, 2.0
    truth["PHIDP"][NEAREST, 2], err["PHIDP"][:, 2] = 1.0, -2.0
    truth["VRADH"][NEAREST, 0], err["VRADH"][:, 0] = 7.5, 1.0
    est = {}
    for k in MOMENTS:
        value = truth[k][NEAREST, :N_GATES] + err[k]
        if k == "VRADH":  # the estimate is folded into the Nyquist interval
            period = 2 * NYQUIST[:, None]
            value = (value + period / 2) % period - period / 2
        if k == "PHIDP":
            value = value % 360
        est[k] = value.astype(np.float32)
    est["VRADH"][:, 4] = np.nan
    moments = xr.Dataset(
        {k: (("beam", "range"), v) for k, v in est.items()},
        coords={"range": ("range", 1000.0 + 250.0 * np.arange(N_GATES))},
        attrs={"blind_range_m": 0.0, "calibration": "boresight"},
    )
    moments["nyquist_velocity"] = ("beam", NYQUIST)
    truth_ds = xr.Dataset(
        {k: (("radial", "gate"), v.astype(np.float32)) for k, v in truth.items()},
        coords={"azimuth": ("radial", RADIAL_AZ)},
    )
    signal = np.zeros((N_BEAMS, N_GATES, 2), np.float32)
    signal[..., 0] = NOISE[0] * 10 ** (SNR_DB / 10)
    signal[..., 1] = NOISE[1] * 10 ** ((SNR_DB - 3) / 10)
    inputs = {
        "moments": moments,
        "truth": truth_ds,
        "signal_power": signal,
        "noise_power": NOISE,
        "beams": beams(),
    }
    t_near = {k: truth_ds[k].values[NEAREST, :N_GATES].astype(np.float64) for k in MOMENTS}
    return inputs, err, est, t_near


def expected_mask(name: str, est: dict, t_near: dict) -> np.ndarray:
    """The documented scoring rule, evaluated here."""
    dbz_ok = t_near["DBZH"] >= 10.0
    snr_ok = (SNR_DB >= 10.0)[None, :]
    return dbz_ok & snr_ok & np.isfinite(est[name]) & np.isfinite(t_near[name])


def score(inputs: dict, **params: float) -> xr.Dataset:
    block = NexradScorer(name="score", **params)
    return block.process(inputs, Chunk(beams=np.arange(N_BEAMS)))["scores"]


def test_beams_sit_where_the_test_assumes() -> None:
    """Sanity of the fixture: the beams are at 359, 0 and 1 deg, nearest radials 1, 2, 3."""
    np.testing.assert_allclose(beams()["azimuth"].values, [359.0, 0.0, 1.0])


def test_errors_are_the_injected_ones_where_scored() -> None:
    """Errors = estimate - truth of the nearest radial (wrapped), i.e. the injected errors,
    where the rule holds, NaN elsewhere."""
    inputs, err, est, t_near = scene()
    out = score(inputs)
    for name in MOMENTS:
        mask = expected_mask(name, est, t_near)
        got = out[f"error_{name}"].values
        assert np.array_equal(np.isfinite(got), mask), name
        np.testing.assert_allclose(got[mask], err[name][mask], atol=1e-4, err_msg=name)
        # The truth on the beam grid is the nearest radial's, truncated to the moment gates.
        np.testing.assert_allclose(
            out[f"truth_{name}"].values, t_near[name].astype(np.float32), equal_nan=True
        )
    # The rule's gates: 1 (DBZH 9.5) and 3 (SNR 9.5 dB) never scored, 2 (DBZH 10) scored,
    # 4 only VRADH unscored, 5 only ZDR unscored.
    for name in MOMENTS:
        got = np.isfinite(out[f"error_{name}"].values)
        assert not got[:, 1].any() and not got[:, 3].any() and got[:, 2].all(), name
        assert got[:, 4].all() == (name != "VRADH"), name
        assert got[:, 5].all() == (name != "ZDR"), name


def test_wrapped_errors_cross_the_fold() -> None:
    """Velocity errors across +-Nyquist and phi_DP errors across 0/360 are the small
    injected ones, not 2 v_a or 360 off: 359 -> 1 deg is +2, 1 -> 359 deg is -2, and a
    truth of 7.5 m/s estimated as -7.5 m/s (Nyquist 8) is +1 m/s."""
    inputs, _, est, _ = scene()
    out = score(inputs)
    np.testing.assert_allclose(est["PHIDP"][:, 0], 1.0, atol=1e-4)  # the raw values fold
    np.testing.assert_allclose(est["PHIDP"][:, 2], 359.0, atol=1e-4)
    np.testing.assert_allclose(est["VRADH"][:, 0], [-7.5, -7.5, 8.5], atol=1e-4)
    np.testing.assert_allclose(out["error_PHIDP"].values[:, 0], 2.0, atol=1e-4)
    np.testing.assert_allclose(out["error_PHIDP"].values[:, 2], -2.0, atol=1e-4)
    np.testing.assert_allclose(out["error_VRADH"].values[:, 0], 1.0, atol=1e-4)


def test_snr_is_expected_signal_over_noise() -> None:
    """SNRH = 10 log10(S_H / N_H) from the expected signal power and the H noise."""
    inputs, *_ = scene()
    out = score(inputs)
    np.testing.assert_allclose(out["SNRH"].values, np.broadcast_to(SNR_DB, (3, 6)), atol=1e-4)


def test_thresholds_are_parameters() -> None:
    """Lowering both thresholds scores the low-reflectivity and low-SNR gates too."""
    inputs, err, _, _ = scene()
    out = score(inputs, min_reflectivity_dbz=5.0, min_snr_db=5.0)
    got = out["error_DBZH"].values
    assert np.isfinite(got).all()
    np.testing.assert_allclose(got, err["DBZH"], atol=1e-4)


def test_error_attributes_carry_table_3() -> None:
    """Each error variable: pasim_role error, its moment, and the paper's Table 3 numbers."""
    inputs, *_ = scene()
    out = score(inputs)
    for name, (req_bias, req_std) in TABLE_3.items():
        attrs = out[f"error_{name}"].attrs
        assert attrs["pasim_role"] == "error"
        assert attrs["moment"] == name
        assert attrs["requirement_bias"] == req_bias
        assert attrs["requirement_std"] == req_std
        assert "DBZH >= 10" in attrs["scored"]
    assert out["error_ZDR"].attrs["units"] == "dB"
    assert out["error_PHIDP"].attrs["units"] == "degrees"


def test_summarize_scorer_output_agrees_with_numpy() -> None:
    """``summarize`` on the scorer output: bias = mean, std (ddof 1), count = scored gates,
    computed here from the injected errors; pass = |bias| <= req and std <= req (Table 3).
    A ZDR bias of 0.5 dB (requirement 0.1 dB) must fail, a DBZH bias of 0.2 dB pass."""
    inputs, err, est, t_near = scene(seed=3, biases={"ZDR": 0.5, "DBZH": 0.2})
    summary = summarize(score(inputs))
    assert set(summary) == set(MOMENTS)
    for name, (req_bias, req_std) in TABLE_3.items():
        values = err[name][expected_mask(name, est, t_near)]
        s = summary[name]
        assert s["count"] == values.size
        assert s["bias"] == pytest.approx(values.mean(), abs=1e-4)
        assert s["std"] == pytest.approx(values.std(ddof=1), abs=1e-4)
        assert s["requirement_bias"] == req_bias and s["requirement_std"] == req_std
        assert s["pass"] == bool(abs(values.mean()) <= req_bias and values.std(ddof=1) <= req_std)
    assert summary["ZDR"]["pass"] is False
    assert summary["DBZH"]["pass"] is True


def test_summarize_hand_made_sweep() -> None:
    """A hand-made sweep: only variables with pasim_role = error count; NaNs are skipped; a
    single value has no std; an empty field has count 0 and does not pass."""
    errors = np.array([[0.5, -0.25, np.nan], [1.5, np.nan, 0.0]])
    attrs = {"pasim_role": "error", "requirement_bias": 1.0, "requirement_std": 1.0}
    sweep = xr.Dataset(
        {
            "error_DBZH": (("azimuth", "range"), errors, {**attrs, "moment": "DBZH"}),
            "error_ZDR": (("azimuth", "range"), [[np.nan, 0.3, np.nan], [np.nan] * 3],
                          {**attrs, "moment": "ZDR"}),
            "error_RHOHV": (("azimuth", "range"), np.full((2, 3), np.nan),
                            {**attrs, "moment": "RHOHV"}),
            "DBZH": (("azimuth", "range"), np.ones((2, 3)), {"units": "dBZ"}),
        }
    )  # fmt: skip
    summary = summarize(sweep)
    assert set(summary) == {"DBZH", "ZDR", "RHOHV"}
    finite = errors[np.isfinite(errors)]
    assert summary["DBZH"]["count"] == 4
    assert summary["DBZH"]["bias"] == pytest.approx(np.mean(finite), abs=1e-12)
    assert summary["DBZH"]["std"] == pytest.approx(np.std(finite, ddof=1), abs=1e-12)
    assert summary["DBZH"]["pass"] is True  # bias 0.44, std 0.77 (by hand)
    assert summary["ZDR"]["count"] == 1
    assert summary["ZDR"]["bias"] == pytest.approx(0.3)
    assert np.isnan(summary["ZDR"]["std"]) and summary["ZDR"]["pass"] is False
    assert summary["RHOHV"]["count"] == 0 and summary["RHOHV"]["pass"] is False
