"""The Py-ART algorithm blocks (blocks/algorithms/), each alone on a small synthetic sweep
whose right answer is known from theory or an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.algorithms.attenuation import ZPhiAttenuation
from pasim_blocks.algorithms.dealias import VelocityDealias
from pasim_blocks.algorithms.despeckle import Despeckle
from pasim_blocks.algorithms.kdp import KdpEstimate
from pasim_blocks.algorithms.rain_rate import RainRate
from pasim_blocks.algorithms.sweep_radar import ALGORITHM_FIELDS

from pasim_graph import Chunk

DIMS = ("beam", "range")
GATE_M = 250.0


def sweep(n_beams: int = 20, n_gates: int = 200, **fields: np.ndarray):
    """Moments and scores of a synthetic PPI sweep (0.5 deg, 1 deg beams, 250 m gates from
    2 km), every gate scored; ``fields``: DBZH, VRADH, PHIDP, ZDR and their truth_*."""
    coords = {
        "azimuth": ("beam", np.arange(n_beams, dtype=np.float64)),
        "elevation": ("beam", np.full(n_beams, 0.5)),
        "range": ("range", 2000.0 + GATE_M * np.arange(n_gates)),
    }
    moments = xr.Dataset(
        {k: (DIMS, v.astype(np.float32)) for k, v in fields.items() if not k.startswith("t")},
        coords=coords,
    )
    moments["nyquist_velocity"] = ("beam", np.full(n_beams, 8.0))
    scores = xr.Dataset(
        {k: (DIMS, v.astype(np.float32)) for k, v in fields.items() if k.startswith("truth_")},
        coords=coords,
    )
    scores["scored"] = (DIMS, np.ones((n_beams, n_gates), np.int8), {"scored": "every gate"})
    return moments, scores


def run(block, moments, scores, **more):
    out = block.process({"moments": moments, "scores": scores, **more}, Chunk(np.arange(3)))
    (value,) = out.values()
    assert ALGORITHM_FIELDS.check(value) == []  # what it returns is what it declares
    return value


def wrap(v: np.ndarray, nyquist: float) -> np.ndarray:
    return (v + nyquist) % (2 * nyquist) - nyquist


@pytest.mark.parametrize("method", ["region", "unwrap_phase"])
def test_dealiasing_recovers_a_smooth_folded_field(method):
    """A smooth velocity field up to 14 m/s, folded into +-8 m/s: dealiased, it is the field
    itself (the independent answer) at every gate, and its error field is zero."""
    az, r = np.meshgrid(np.arange(20), np.arange(200), indexing="ij")
    truth = 14.0 * np.sin(np.pi * r / 200) * np.cos(np.pi * az / 40)
    moments, scores = sweep(VRADH=wrap(truth, 8.0), truth_VRADH=truth)
    out = run(VelocityDealias("d", method=method), moments, scores)
    name = "VRADH_DEALIASED_REGION" if method == "region" else "VRADH_DEALIASED_UNWRAP"
    folded = np.abs(truth) > 8.0
    assert folded.mean() > 0.2
    np.testing.assert_allclose(out[name].values, truth, atol=1e-3)
    assert np.nanmax(np.abs(out[f"error_{name}"].values)) < 1e-3
    assert out[f"error_{name}"].attrs["pasim_role"] == "error"


def test_unwrap_phase_repeats_itself_and_refuses_a_two_beam_sweep():
    """Same sweep, same answer (the seed rule): Py-ART's 2-D unwrapping of a two-beam sweep
    differed between calls in one process, so two beams are refused in one line; on three
    beams and more, three calls give one answer to the bit."""
    az, r = np.meshgrid(np.arange(3), np.arange(200), indexing="ij")
    truth = 20.0 * np.sin(np.deg2rad(280 + az)) + np.linspace(-15, 15, 200)[None, :] + 0 * r
    moments, scores = sweep(3, VRADH=wrap(truth, 8.0), truth_VRADH=truth)
    block = VelocityDealias("d", method="unwrap_phase")
    answers = [run(block, moments, scores)["VRADH_DEALIASED_UNWRAP"].values for _ in range(3)]
    for a in answers[1:]:
        np.testing.assert_array_equal(a, answers[0])
    two, scores2 = sweep(2, VRADH=wrap(truth[:2], 8.0), truth_VRADH=truth[:2])
    with pytest.raises(ValueError, match=r"at least 3 beams \(this one has 2\).*method: region"):
        run(block, two, scores2)


def test_dealiasing_refuses_a_sweep_without_velocity():
    moments, scores = sweep(DBZH=np.zeros((20, 200)), truth_VRADH=np.zeros((20, 200)))
    with pytest.raises(ValueError, match="block 'd' needs VRADH in the sweep"):
        run(VelocityDealias("d"), moments, scores)


@pytest.mark.parametrize("method", ["vulpiani", "maesaka"])
def test_kdp_of_a_linear_phidp_is_half_its_slope(method):
    """phi_DP rising 2 deg/km along every ray: KDP = 1/2 d(phi_DP)/dr = 1 deg/km (theory)
    away from the ends of the ray; the truth's phi_DP is the same at the same frequency, so
    the error against the same estimator on it is zero."""
    r_km = (2000.0 + GATE_M * np.arange(200)) / 1e3
    phidp = np.broadcast_to(2.0 * (r_km - r_km[0]), (6, 200)).copy()
    moments, scores = sweep(6, PHIDP=phidp, truth_PHIDP=phidp)
    block = KdpEstimate("k", method=method, frequency_hz=5.6e9, truth_frequency_hz=5.6e9)
    out = run(block, moments, scores)
    name = f"KDP_{method.upper()}"
    kdp = out[name].values[:, 30:-30]
    assert np.median(kdp) == pytest.approx(1.0, abs=0.05)
    assert np.nanmax(np.abs(out[f"error_{name}"].values)) < 1e-5


def test_zphi_undoes_the_attenuation_of_a_rain_cell():
    """A rain cell (KDP peaking at 1 deg/km, 5 km wide, at 15 km), Z drawn from Z-PHI's own
    model (A_H = a KDP with a = 0.08 dB/deg, A_H proportional to Z^b with b = 0.649: Py-ART's
    C-band coefficients), attenuated by the forward model's two-way path: behind the cell the
    loss is 2 a int KDP dr = 1.42 dB (computed here); Z-PHI gives back the true Z there
    within 0.3 dB."""
    x_km = GATE_M * np.arange(200) / 1e3
    kdp = np.exp(-(((x_km - 15.0) / 5.0) ** 2))
    true_z = np.broadcast_to(np.maximum(45.0 + 10 / 0.64884 * np.log10(kdp), -10.0), (6, 200))
    path = 2.0 * np.cumsum(kdp) * GATE_M / 1e3  # two-way phase (deg)
    attenuated = true_z - 0.08 * path
    phidp = np.broadcast_to(path, (6, 200))
    zeros = np.zeros((6, 200))
    moments, scores = sweep(6, DBZH=attenuated, PHIDP=phidp, ZDR=zeros, truth_DBZH=true_z)
    out = run(ZPhiAttenuation("z", frequency_hz=5.6e9), moments, scores)
    behind = (x_km > 28.0) & (x_km < 40.0)
    loss = np.mean((true_z - attenuated)[:, behind])
    assert loss == pytest.approx(0.08 * 2 * 5 * np.sqrt(np.pi), abs=0.01)  # 1.42 dB
    error = out["error_DBZH_ZPHI"].values[:, behind]
    assert abs(np.nanmean(error)) < 0.3 < loss


def test_despeckle_removes_isolated_gates_and_keeps_the_echo():
    """A 10 x 50 gate echo and three isolated gates: the isolated ones go (fewer than 10
    gates each), the echo stays; the truth (the echo alone) is unchanged by the filter."""
    echo = np.full((20, 200), np.nan)
    echo[5:15, 50:100] = 30.0
    speckled = echo.copy()
    speckled[2, 150] = speckled[17, 10] = speckled[18, 180] = 25.0
    moments, scores = sweep(DBZH=speckled, truth_DBZH=echo)
    out = run(Despeckle("s"), moments, scores)
    np.testing.assert_array_equal(out["DBZH_DESPECKLED"].values, echo.astype(np.float32))
    np.testing.assert_array_equal(out["ideal_DBZH_DESPECKLED"].values, echo.astype(np.float32))


def test_rain_rate_from_z_and_kdp_follow_their_power_laws():
    """R(Z) = 0.0376 Z^0.6112 (Z in mm^6 m^-3) and R(KDP) = alpha KDP^beta with Py-ART's C-band
    coefficients, computed here; the ideal answer of both is R(Z) of the truth's Z."""
    from pasim_blocks.algorithms.sweep_radar import pyart

    dbz = np.linspace(10.0, 50.0, 200)[None, :].repeat(4, axis=0)
    moments, scores = sweep(4, DBZH=dbz, truth_DBZH=dbz + 1.0)
    kdp = xr.Dataset({"KDP_VULPIANI": (DIMS, np.full((4, 200), 0.5, np.float32))})
    out = run(RainRate("r", frequency_hz=5.6e9), moments, scores, kdp=kdp)
    np.testing.assert_allclose(out["RATE_Z"].values, 0.0376 * (10 ** (dbz / 10)) ** 0.6112, 1e-5)
    ideal = 0.0376 * (10 ** ((dbz + 1.0) / 10)) ** 0.6112
    np.testing.assert_allclose(out["ideal_RATE_Z"].values, ideal, rtol=1e-5)
    alpha, beta = pyart().retrieve.qpe._get_coeff_rkdp(5.6e9)
    np.testing.assert_allclose(out["RATE_KDP"].values, alpha * 0.5**beta, rtol=1e-5)
    np.testing.assert_allclose(
        out["error_RATE_KDP"].values, alpha * 0.5**beta - ideal, rtol=1e-4, atol=1e-4
    )
