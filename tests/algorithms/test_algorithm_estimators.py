"""Z-PHI with the propagation path's coefficients, and Schneebeli's KDP estimator, each alone
on a small synthetic sweep whose right answer is known (docs/algorithms.md)."""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.algorithms.attenuation import ZPhiAttenuation
from pasim_blocks.algorithms.kdp import KdpEstimate
from pasim_blocks.propagation.rain import coefficients

from .test_algorithms import GATE_M, run, sweep


def rain_cell(alpha: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A rain cell (KDP peaking at 1 deg/km, 5 km wide, at 15 km) seen at C band through a
    path whose specific attenuation is ``alpha`` KDP: range (km), true Z, attenuated Z and
    the two-way phi_DP. Z follows Z-PHI's A_H ~ Z^b (b = 0.649, Py-ART's C band)."""
    x_km = GATE_M * np.arange(200) / 1e3
    kdp = np.exp(-(((x_km - 15.0) / 5.0) ** 2))
    true_z = np.broadcast_to(np.maximum(45.0 + 10 / 0.64884 * np.log10(kdp), -10.0), (6, 200))
    path = 2.0 * np.cumsum(kdp) * GATE_M / 1e3  # two-way phase (deg)
    return x_km, true_z, true_z - alpha * path, np.broadcast_to(path, (6, 200))


@pytest.mark.parametrize("coefficients_", ["propagation", "pyart"])
def test_zphi_with_the_paths_alpha_undoes_the_paths_attenuation(coefficients_):
    """The cell attenuated with the propagation path's alpha at 5.6 GHz (0.07 dB/deg,
    pasim_blocks.propagation.rain): behind it the loss is 2 alpha int KDP dr = 1.24 dB.
    Z-PHI with ``coefficients: propagation`` gives the true Z back within 0.1 dB; with
    Py-ART's C-band alpha (0.08) it over-corrects by (0.08 - alpha) times the phase there,
    0.18 dB (theory: Z-PHI's path-integrated attenuation at the ray's end is alpha times
    the phase)."""
    alpha = coefficients(5.6e9)[0]
    assert alpha == pytest.approx(0.07)
    x_km, true_z, attenuated, phidp = rain_cell(alpha)
    zeros = np.zeros((6, 200))
    moments, scores = sweep(6, DBZH=attenuated, PHIDP=phidp, ZDR=zeros, truth_DBZH=true_z)
    block = ZPhiAttenuation("z", frequency_hz=5.6e9, coefficients=coefficients_)
    out = run(block, moments, scores)
    behind = (x_km > 28.0) & (x_km < 40.0)
    phase = 2 * 5 * np.sqrt(np.pi)  # two-way phase behind the cell (deg): 17.7
    assert np.mean((true_z - attenuated)[:, behind]) == pytest.approx(alpha * phase, abs=0.01)
    error = float(np.nanmean(out["error_DBZH_ZPHI"].values[:, behind]))
    expected = 0.0 if coefficients_ == "propagation" else (0.08 - alpha) * phase
    assert error == pytest.approx(expected, abs=0.1)


@pytest.mark.slow  # four runs of Schneebeli's filter: about 16 s on 2 busy cores
def test_schneebeli_kdp_of_a_linear_phidp_repeats_itself():
    """phi_DP rising 2 deg/km: Schneebeli's Kalman-filter ensemble gives KDP = 1 deg/km
    (theory: half the slope) away from the ray's ends. Its filter draws from NumPy's global
    random state: the block seeds it, so a second call gives the same KDP to the bit, and the
    caller's random state is left as it was."""
    r_km = (2000.0 + GATE_M * np.arange(120)) / 1e3
    phidp = np.broadcast_to(2.0 * (r_km - r_km[0]), (3, 120)).copy()
    moments, scores = sweep(3, 120, PHIDP=phidp, truth_PHIDP=phidp)
    block = KdpEstimate("k", method="schneebeli", frequency_hz=5.6e9, truth_frequency_hz=5.6e9)
    np.random.seed(7)  # noqa: NPY002 (the global state the block must leave alone)
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    first = run(block, moments, scores)
    assert np.array_equal(np.random.get_state()[1], before)  # noqa: NPY002
    second = run(block, moments, scores)
    kdp = first["KDP_SCHNEEBELI"].values
    assert np.array_equal(kdp, second["KDP_SCHNEEBELI"].values, equal_nan=True)
    assert np.median(kdp[:, 20:-20]) == pytest.approx(1.0, abs=0.1)
    assert np.nanmax(np.abs(first["error_KDP_SCHNEEBELI"].values)) < 1e-5


def test_a_rhohv_gate_filter_keeps_a_weak_far_echos_phase_out_of_zphi():
    """The rain cell attenuated with the path's alpha, then weak echo (5 dBZ) at 42-50 km
    whose phi_DP climbs 20 deg that are not propagation (noise of weak echo: rho_hv 0.6
    there, 0.99 in the rain). Z-PHI fixes a ray's attenuation at alpha times its end phase,
    so without a filter the climb (0.07 x 20 = 1.4 dB at the end) over-corrects the cell's
    shadow by more than 0.5 dB; with ``min_rhohv: 0.8`` those gates are left out and the true
    Z is given back within 0.1 dB (as without the climb), and the gates left out have no
    corrected Z."""
    alpha = coefficients(5.6e9)[0]
    x_km, true_z, attenuated, phidp = rain_cell(alpha)
    weak = x_km >= 42.0
    true_z, attenuated, phidp = true_z.copy(), attenuated.copy(), phidp.copy()
    true_z[:, weak] = 5.0
    attenuated[:, weak] = 5.0 - phidp[:, weak] * alpha
    phidp[:, weak] += 20.0 * (x_km[weak] - 42.0) / 8.0
    rhohv = np.where(weak, 0.6, 0.99) * np.ones((6, 1))
    zeros = np.zeros((6, 200))
    moments, scores = sweep(
        6, DBZH=attenuated, PHIDP=phidp, ZDR=zeros, RHOHV=rhohv, truth_DBZH=true_z
    )
    behind = (x_km > 28.0) & (x_km < 40.0)
    errors = {}
    for threshold in (None, 0.8):
        block = ZPhiAttenuation(
            "z", frequency_hz=5.6e9, coefficients="propagation", min_rhohv=threshold
        )
        out = run(block, moments, scores)
        errors[threshold] = float(np.nanmean(out["error_DBZH_ZPHI"].values[:, behind]))
        if threshold is not None:
            assert np.isnan(out["DBZH_ZPHI"].values[:, weak]).all()
    assert errors[None] > 0.5
    assert errors[0.8] == pytest.approx(0.0, abs=0.1)


def kdp_rows_in_the_docs() -> dict[str, tuple[float, float]]:
    """Bias and std of each estimator of docs/algorithms.md's 297-303 deg table."""
    from ..conftest import ROOT

    text = (ROOT / "docs" / "algorithms.md").read_text()
    table = text[text.index("| estimator, 297-303 deg") :].split("\n\n", 1)[0].splitlines()[2:]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table]
    return {r[0].upper(): (float(r[1]), float(r[2])) for r in rows}


@pytest.mark.slow  # Schneebeli on 6 beams of the storm: 100-160 s on 2 busy cores
def test_schneebeli_beside_maesaka_on_the_storm(capsys, tmp_path):
    """docs/algorithms.md's Schneebeli and Maesaka rows on 297-303 deg of
    graphs/algorithms_cband.yaml: each estimate minus its ideal answer (the same estimator on
    the truth's phi_DP, stored beside it), computed here on the scored gates, is the docs'
    bias and std to their two decimals."""
    import xarray as xr

    from ..conftest import GRAPHS, pasim_out

    out = tmp_path / "kdp.zarr"
    graph = str(GRAPHS / "algorithms_cband.yaml")
    more = ["--sector", "297:303", "--set", "kdp.method=schneebeli"]
    code, _, err = pasim_out(capsys, "run", graph, "--out", str(out), *more)
    assert code == 0, err
    s = xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()
    gates = s["scored"].values.astype(bool)
    docs = kdp_rows_in_the_docs()
    for method in ("MAESAKA", "SCHNEEBELI"):
        d = s[f"KDP_{method}"].values.astype(np.float64) - s[f"ideal_KDP_{method}"].values
        x = d[gates & np.isfinite(d)]
        assert (round(float(x.mean()), 2), round(float(x.std(ddof=1)), 2)) == docs[method]
