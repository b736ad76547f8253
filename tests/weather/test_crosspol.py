"""Cross-polar coupling through the weather channel (``blocks/weather.py``, docs/arrays.md).

The weather channel couples H and V through the antenna's complex co- and cross-polar fields
(``co_polar``, ``cross_polar``): for each truth cell the received channels' covariance is the
integral over the cell's directions of M C_s M^H. Each test runs a uniform synthetic scene
(tests/weather/test_block_weather.py) through the weather channel and the pulse-pair processor, and
compares with:

* the coupling model of Zrnic, Doviak, Zhang and Ryzhkov (2010, JTECH 27) for an antenna
  whose cross-polar pattern is x times its co-polar one (isotropic elements with a leakage
  x, phase 1's ``cross_pol_db``): their first-order SHV ZDR bias, and the exact (all-orders)
  bias of the same model, written out here by hand (``tests/weather/test_polarimetry.py``);
* AHV: the exact and second-order bias of that model, derived in docs/arrays.md;
* the two-way H/V ratio at the beam peak (``pasim pattern``'s ``zdr_bias_db``) for the
  steered planar array, and the first-order SHV coupling of the patch's geometric
  cross-polar field off the principal planes;
* the power-pattern model the channel used before, for antennas without a cross-polar field.
"""

from __future__ import annotations

import numpy as np
import pytest
from pasim_blocks.antennas.planar import PlanarPatchArray
from pasim_blocks.processing.pulse_pair import PulsePairProcessor
from pasim_blocks.signals import SPEED_OF_LIGHT
from pasim_blocks.weather.channel import WeatherChannel

from pasim_graph import Chunk

from .test_block_weather import chain_inputs, uniform_truth
from .test_polarimetry import closed_form_bias_db, first_order_bias_db

ZDR_DB, RHO, PHIDP_DEG = 2.0, 0.98, 30.0
LEVELS_DB = (-20.0, -25.0, -30.0, -35.0, -40.0)


def leaky_array(level_db: float | None, phase_deg: float = 0.0, face_deg: float = 100.5):
    """30 x 30 isotropic elements, each port leaking x = level e^{j phase} of the other's
    field: F = AF [[1, x], [x, 1]], the cross-polar pattern shaped as the co-polar one."""
    return PlanarPatchArray(
        name="antenna",
        n_x=30,
        n_y=30,
        face_azimuth_deg=face_deg,
        grid_step_deg=0.15,
        support_deg=8.0,
        element="isotropic",
        cross_pol_db=level_db,
        cross_pol_phase_deg=phase_deg,
    )


def scene(
    n_beams: int = 2,
    n_gates: int = 16,
    azimuths=None,
    elevation: float | None = None,
    **fields: float,
):
    values = {"ZDR": ZDR_DB, "RHOHV": RHO, "PHIDP": PHIDP_DEG, **fields}
    inputs = chain_inputs(uniform_truth(n_gates=n_gates, **values), np.arange(n_beams))
    if azimuths is not None:
        inputs["beams"] = inputs["beams"].assign_coords(azimuth=("beam", np.asarray(azimuths)))
    if elevation is not None:
        beams = inputs["beams"]
        inputs["beams"] = beams.assign_coords(elevation=("beam", np.full(n_beams, elevation)))
    return inputs


def with_antenna(inputs: dict, block) -> dict:
    beams = np.arange(inputs["beams"].sizes["beam"])
    pattern = block.process({"beams": inputs["beams"]}, Chunk(beams=beams))["pattern"]
    return inputs | {"pattern": pattern}


def moments(inputs: dict, method: str = "expected", seed: int = 0, **weather):
    """The processor's moments (no noise, no censoring) away from the scene's range edges."""
    beams = np.arange(inputs["beams"].sizes["beam"])
    out = WeatherChannel(name="weather", method=method, **weather).process(
        inputs, Chunk(beams=beams, seed=seed, block_name="weather")
    )
    ppp = PulsePairProcessor(
        name="ppp",
        snr_threshold_reflectivity_db=None,
        snr_threshold_doppler_db=None,
        snr_threshold_polarimetric_db=None,
    )
    m = ppp.process(
        {
            "iq": out["iq"],
            "noise_power": np.zeros((*out["iq"].shape[:2], 2)),
            "calibration": out["calibration"],
            "beams": inputs["beams"],
            "echo_correlations": out["echo_correlations"],
        },
        Chunk(beams=beams, expected=method == "expected"),
    )["moments"]
    return m.isel(range=slice(3, -3))


def worst_beta(x: complex) -> float:
    """The transmit differential phase (1-deg grid) that maximises the first-order bias."""
    betas = np.arange(0.0, 360.0, 1.0)
    bias = [abs(first_order_bias_db(x, b, ZDR_DB, RHO, PHIDP_DEG)) for b in betas]
    return float(betas[int(np.argmax(bias))])


def ahv_bias_db(x: complex, order: int | None = None) -> float:
    """AHV ZDR bias of the coincident-pattern model (docs/arrays.md): on H pulses v_H =
    f^2 (s_hh + x^2 s_vv), on V pulses v_V = f^2 (x^2 s_hh + s_vv), so
    Zdr_m / Zdr = [1 + 2 Re(x^2 r) / sqrt(Zdr) + |x|^4 / Zdr] /
                  [1 + 2 Re(x*^2 r) sqrt(Zdr) + |x|^4 Zdr],  r = rho e^{j phi_DP};
    ``order=2`` keeps the second-order terms only."""
    z = 10 ** (ZDR_DB / 10)
    r = RHO * np.exp(1j * np.deg2rad(PHIDP_DEG))
    if order == 2:
        ratio = (
            1 + 2 * np.real(x**2 * r) / np.sqrt(z) - 2 * np.real(np.conj(x) ** 2 * r) * np.sqrt(z)
        )
    else:
        num = 1 + 2 * np.real(x**2 * r) / np.sqrt(z) + abs(x) ** 4 / z
        den = 1 + 2 * np.real(np.conj(x) ** 2 * r) * np.sqrt(z) + abs(x) ** 4 * z
        ratio = num / den
    return float(10 * np.log10(ratio))


@pytest.mark.parametrize("phase_deg", [0.0, 90.0])
def test_shv_zdr_bias_against_zrnic_2010(phase_deg: float) -> None:
    """SHV ZDR bias of a uniform medium through the weather channel (expected level) against
    the cross-polar level, for the transmit differential phase beta that maximises the bias
    and for beta + 90 deg. It equals the exact bias of the coupling model at every level
    (within 0.2 % or 2e-4 dB), and the first-order formula of Zrnic et al. (2010) within
    10 % wherever that formula holds, -35 and -40 dB (at -20 to -30 dB its neglected terms of
    order |x|^2 are up to 13 % (real x) and 49 % (x in quadrature) of the bias: the
    formula's truncation, tabulated in docs/arrays.md). The bias is first order: from -40 to
    -20 dB it grows close to 10x, as |x|."""
    inputs = scene()
    for level in LEVELS_DB:
        x = 10 ** (level / 20) * np.exp(1j * np.deg2rad(phase_deg))
        leaky = with_antenna(inputs, leaky_array(level, phase_deg))
        beta_max = worst_beta(x)
        for beta in (beta_max, (beta_max + 90.0) % 360.0):
            m = moments(leaky, transmission="shv", transmit_differential_phase_deg=beta)
            bias = float(m["ZDR"].mean()) - ZDR_DB
            exact = closed_form_bias_db(x, beta, ZDR_DB, RHO, PHIDP_DEG)
            assert bias == pytest.approx(exact, rel=2e-3, abs=2e-4), (level, beta)
            if level <= -35.0 and beta == beta_max:
                first = first_order_bias_db(x, beta, ZDR_DB, RHO, PHIDP_DEG)
                assert bias == pytest.approx(first, rel=0.10), (level, beta)
    biases = {}
    for level in (-20.0, -40.0):
        x = 10 ** (level / 20) * np.exp(1j * np.deg2rad(phase_deg))
        m = moments(
            with_antenna(inputs, leaky_array(level, phase_deg)),
            transmit_differential_phase_deg=worst_beta(x),
        )
        biases[level] = float(m["ZDR"].mean()) - ZDR_DB
    assert 5.0 < biases[-20.0] / biases[-40.0] < 11.0


def test_ahv_removes_the_first_order_term() -> None:
    """AHV through the weather channel: the ZDR bias equals the exact AHV bias of the same
    model, and its second-order term within 10 % (fourth-order terms are |x|^2 of it); it
    scales as |x|^2 (x100 from -40 to -20 dB), so it is below 1.5 |x| times the worst SHV
    bias at each level (measured 0.1 |x| to 0.95 |x|: 11 to 1000 times smaller). rho_hv and
    phi_DP also move at second order only (AHV estimators with the lag-2 coherency
    correction), where SHV moves phi_DP at first order."""
    inputs = scene()
    for phase_deg in (0.0, 90.0):
        biases = {}
        for level in LEVELS_DB:
            x = 10 ** (level / 20) * np.exp(1j * np.deg2rad(phase_deg))
            leaky = with_antenna(inputs, leaky_array(level, phase_deg))
            ahv = moments(leaky, transmission="ahv")
            bias = float(ahv["ZDR"].mean()) - ZDR_DB
            assert bias == pytest.approx(ahv_bias_db(x), rel=2e-3, abs=2e-6), level
            assert bias == pytest.approx(ahv_bias_db(x, order=2), rel=0.10), level
            shv = moments(leaky, transmit_differential_phase_deg=worst_beta(x))
            shv_bias = float(shv["ZDR"].mean()) - ZDR_DB
            assert abs(bias) < 1.5 * abs(x) * abs(shv_bias), level
            phi_shift = float(ahv["PHIDP"].mean()) - PHIDP_DEG
            assert abs(phi_shift) < np.rad2deg(4 * abs(x) ** 2), level
            assert abs(float(ahv["RHOHV"].mean()) - RHO) < 4 * abs(x) ** 2, level
            biases[level] = bias
        assert biases[-20.0] / biases[-40.0] == pytest.approx(100.0, rel=0.05)
    # SHV's phi_DP bias is first order (x in quadrature, beta = 0): ratio sqrt(10) per 10 dB.
    shifts = [
        float(moments(with_antenna(inputs, leaky_array(lv, 90.0)))["PHIDP"].mean()) - PHIDP_DEG
        for lv in (-30.0, -40.0)
    ]
    assert shifts[0] / shifts[1] == pytest.approx(np.sqrt(10), rel=0.1)


@pytest.mark.parametrize(
    ("method", "mode", "width"),
    [
        ("combined", "shv", None),
        ("covariance", "shv", None),
        ("monte_carlo", "shv", None),
        ("combined", "ahv", None),
        ("covariance", "ahv", None),
        ("monte_carlo", "ahv", None),
        # Zero spectrum width: the combined level's tones, not its spectral draw.
        ("combined", "shv", 0.0),
        ("combined", "ahv", 0.0),
    ],
)
def test_random_levels_have_the_expected_bias(method: str, mode: str, width) -> None:
    """-25 dB leakage in quadrature: the mean ZDR bias over 4 beams x 50 gates of a random
    level equals the expected level's (the exact bias above) within 3 standard errors (the
    spread over every other gate, which the range response leaves uncorrelated, over the
    square root of their number) plus 0.002 dB for the ratio estimator's own bias at M = 64;
    SHV at the worst transmit phase, AHV at beta = 0."""
    level, phase = -25.0, 90.0
    x = 10 ** (level / 20) * np.exp(1j * np.deg2rad(phase))
    beta = worst_beta(x) if mode == "shv" else 0.0
    fields = {} if width is None else {"WRADH": width}
    inputs = with_antenna(scene(n_beams=4, n_gates=56, **fields), leaky_array(level, phase))
    kw = {"transmission": mode, "transmit_differential_phase_deg": beta}
    expected = float(moments(inputs, **kw)["ZDR"].mean()) - ZDR_DB
    zdr = moments(inputs, method=method, seed=5, **kw)["ZDR"].values[:, ::2].ravel() - ZDR_DB
    se = zdr.std(ddof=1) / np.sqrt(zdr.size)
    assert abs(zdr.mean() - expected) < 3 * se + 0.002, (zdr.mean(), expected, se)
    assert abs(expected) > (1.0 if mode == "shv" else 0.005)


def pencil_with_fields(inputs: dict) -> dict:
    """The pencil beam's pattern with co_polar = sqrt(power), cross_polar = 0 added."""
    pattern = inputs["pattern"].copy()
    amp = np.sqrt(pattern["power"].values.astype(np.float64))
    dims = pattern["power"].dims
    pattern["co_polar"] = (dims, amp.astype(np.complex64), {"units": "1"})
    pattern["cross_polar"] = (dims, np.zeros_like(amp, np.complex64), {"units": "1"})
    return inputs | {"pattern": pattern}


@pytest.mark.parametrize("mode", ["shv", "ahv"])
def test_without_cross_polar_field_the_coupling_is_the_power_pattern_model(mode: str) -> None:
    """The pencil beam (no cross-polar variables: the power-pattern path, the previous
    channel's) against the same pattern given as complex fields with no cross-polar part
    (the coupled path): the expected correlations agree to 1e-7, the combined level's I/Q
    to 1e-5 (the same random numbers, factored the same way), the covariance level's H
    channel to 1e-5 and its V channel in distribution (its independent part may take another
    phase, which changes nothing: powers within 3 %, rho_hv within 0.002); a transmit
    differential phase without cross-polar field changes no moment."""
    beams = np.arange(3)
    plain = chain_inputs(uniform_truth(n_gates=24, WRADH=1.5), beams, pulses=32)
    fields = pencil_with_fields(plain)
    kw = {"transmission": mode}
    for method in ("expected", "combined", "covariance"):
        chunk = Chunk(beams=beams, seed=2, block_name="weather")
        a = WeatherChannel(name="weather", method=method, **kw).process(plain, chunk)
        b = WeatherChannel(name="weather", method=method, **kw).process(fields, chunk)
        assert a["calibration"].attrs["cross_polar_coupling"] == 0
        assert b["calibration"].attrs["cross_polar_coupling"] == 1
        ca, cb = a["echo_correlations"], b["echo_correlations"]
        np.testing.assert_allclose(cb, ca, rtol=0, atol=1e-7 * np.nanmax(np.abs(ca)))
        if method == "expected":
            continue
        ia, ib = a["iq"].astype(complex), b["iq"].astype(complex)
        scale = np.abs(ia).max()
        if method == "combined":
            np.testing.assert_allclose(ib, ia, rtol=0, atol=1e-5 * scale)
        else:
            h = slice(0, None, 2) if mode == "ahv" else slice(None)
            np.testing.assert_allclose(ib[:, :, h, 0], ia[:, :, h, 0], rtol=0, atol=1e-5 * scale)
            pa, pb = (np.mean(np.abs(i[..., 1]) ** 2) for i in (ia, ib))
            assert pb == pytest.approx(pa, rel=0.03)
    shifted = moments(fields, transmit_differential_phase_deg=70.0, transmission=mode)
    plain_m = moments(plain, transmission=mode)
    for name in ("ZDR", "RHOHV", "PHIDP", "VRADH"):
        np.testing.assert_allclose(shifted[name].values, plain_m[name].values, atol=1e-4)
    plain_shifted = moments(plain, transmit_differential_phase_deg=70.0, transmission=mode)
    np.testing.assert_allclose(plain_shifted["PHIDP"].values, plain_m["PHIDP"].values, atol=1e-4)


PLANAR = dict(
    name="antenna",
    n_x=80,
    n_y=80,
    face_azimuth_deg=285.0,
    taylor_sll_db=-30.0,
    taylor_nbar=5,
    calibration="boresight",
    support_deg=6.0,
)  # graphs/planar_patch_radar.yaml, boresight calibration


def test_planar_zdr_bias_grows_with_steering_and_is_the_two_way_ratio() -> None:
    """The 80 x 80 patch array of graphs/planar_patch_radar.yaml with the broadside constant,
    steered 0, 15, 30 and 45 deg, on a uniform scene at the sweep's 0.5 deg elevation: the ZDR
    bias through the weather channel grows with steering and equals ``pasim pattern``'s
    two-way H/V ratio at the beam peak (``zdr_bias_db``, relative to broadside) within 0.02 dB
    in AHV (the bias integrates the ratio over the beam; measured 0.015 dB off at 45 deg). In
    SHV the patch's geometric cross-polar field (its V port tilts off the principal planes by
    sin(el) tan(az)) adds a first-order coupling: the H power changes by 10 log10(1 + 2 g
    sin(el_b) tan(az_s)), g the one-way V/H amplitude ratio at the peak, checked within 10 %
    on DBZH (SHV minus AHV), with a random level (combined) at 45 deg within 3 standard
    errors."""
    from pasim_blocks.antennas.beam_figures import measure

    block = PlanarPatchArray(**PLANAR)
    steers = np.array([0.0, 15.0, 30.0, 45.0])
    ratio = np.array([measure(block, -s, 0.0, span_deg=10.0)["zdr_bias_db"] for s in steers])
    inputs = with_antenna(scene(n_beams=4, azimuths=285.0 - steers, elevation=0.5), block)
    ahv = moments(inputs, transmission="ahv")
    shv = moments(inputs, transmission="shv")
    bias = ahv["ZDR"].mean("range").values - ZDR_DB
    np.testing.assert_allclose(bias, ratio - ratio[0], atol=0.02)
    assert np.all(np.diff(np.abs(bias)) > 0.3) and abs(bias[-1]) > 3.0
    g = 10 ** (-ratio / 40)  # one-way |F_Vv / F_Hh| at the peak
    coupling = 10 * np.log10(1 + 2 * g * np.sin(np.deg2rad(0.5)) * np.tan(np.deg2rad(-steers)))
    dbz = (shv["DBZH"] - ahv["DBZH"]).mean("range").values
    np.testing.assert_allclose(dbz[1:], coupling[1:], rtol=0.10)
    assert abs(dbz[0]) < 0.002
    drawn = moments(inputs.copy(), method="combined", seed=3, transmission="ahv")
    z = drawn["ZDR"].values[-1] - ZDR_DB
    assert abs(z.mean() - bias[-1]) < 3 * z.std(ddof=1) / np.sqrt(z.size)


def test_cylinder_zdr_bias_is_the_same_at_every_azimuth() -> None:
    """The ideal 10 m CPPAR of graphs/cppar10_radar.yaml with the broadside constant, beams
    every 11.3 deg over 240-330 (columns commutated with the beam): the ZDR bias through the
    weather channel spreads by less than 0.02 dB over azimuth in SHV and AHV (measured 1e-4
    dB), and the uncalibrated two-way H/V ratio is the same everywhere."""
    from pasim_blocks.antennas.cylindrical import CylindricalArray

    block = CylindricalArray(
        name="antenna",
        columns=624,
        diameter_m=10.0,
        elements_per_column=128,
        excited_columns=156,
        spacing_y_m=0.0524,
        taper_axis="columns",
        taylor_nbar=5,
        taylor_sll_db=-30.0,
        calibration="boresight",
        support_deg=4.0,
    )
    azimuths = np.linspace(240.0, 330.0, 9)
    inputs = with_antenna(scene(n_beams=9, azimuths=azimuths, elevation=0.5), block)
    for mode in ("shv", "ahv"):
        beams = np.arange(9)
        out = WeatherChannel(name="weather", method="expected", transmission=mode).process(
            inputs, Chunk(beams=beams, block_name="weather")
        )
        m = moments(inputs, transmission=mode)
        bias = m["ZDR"].mean("range").values - ZDR_DB
        assert np.ptp(bias) < 0.02, mode
        const = out["calibration"]["radar_constant_db"].values
        raw = bias + const[:, 0] - const[:, 1]
        assert np.ptp(raw) < 0.02 and abs(raw.mean()) > 0.3, mode


def test_ahv_graph_runs_end_to_end() -> None:
    """graphs/uniform_ideal.yaml (ideal antenna, fixed SNR) with ``weather.transmission=ahv``
    at the expected and combined levels: the run validates and returns the scene's ZDR,
    rho_hv and phi_DP (mod 180), the velocity folded into the halved Nyquist interval, and
    the scores use it (PHIDP errors on 180 deg)."""
    from pasim_graph.executor import LocalExecutor
    from pasim_graph.graph import load

    from ..conftest import GRAPHS

    for method in ("expected", "combined"):
        graph = load(
            GRAPHS / "uniform_ideal.yaml",
            {
                "scan.azimuth_stop_deg": 6.0,
                "weather.method": method,
                "weather.transmission": "ahv",
            },
        )
        sweep = LocalExecutor(graph).run()
        truth = {k: float(np.nanmedian(sweep[f"truth_{k}"].values)) for k in ("ZDR", "RHOHV")}
        nyquist = float(sweep["nyquist_velocity"].values[0])
        assert nyquist == pytest.approx(SPEED_OF_LIGHT / 2.8e9 / (8 * 1e-3))  # lambda / (8T)
        tol = 1e-3 if method == "expected" else 0.1
        assert float(np.nanmedian(sweep["ZDR"].values)) == pytest.approx(truth["ZDR"], abs=tol)
        assert float(np.nanmedian(sweep["RHOHV"].values)) == pytest.approx(
            truth["RHOHV"], abs=tol / 10
        )
        assert sweep["error_PHIDP"].attrs["period"] == 180.0
        assert "transmission: ahv" in sweep["scored"].attrs["scored"]
        assert np.nanmax(np.abs(sweep["error_PHIDP"].values)) <= 90.0


@pytest.mark.parametrize("mode", ["shv", "ahv"])
@pytest.mark.parametrize("method", ["combined", "covariance", "monte_carlo"])
def test_coupled_levels_draw_each_beam_the_same_whatever_the_chunk(method: str, mode: str) -> None:
    """With cross-polar fields (-25 dB leakage in quadrature, beta 30 deg) every random level
    gives a beam the same I/Q whether it is drawn alone or with three others (the project's
    reproducibility rule: numbers do not depend on chunking or workers)."""
    beams = np.arange(4)
    inputs = with_antenna(scene(n_beams=4, n_gates=12), leaky_array(-25.0, 90.0))
    kw = {
        "method": method,
        "transmission": mode,
        "transmit_differential_phase_deg": 30.0,
        "drops_per_cell": 8,
    }

    def draw(which: np.ndarray) -> np.ndarray:
        sub = {
            "beams": inputs["beams"].isel(beam=which),
            "pattern": inputs["pattern"].isel(beam=which),
        }
        chunk = Chunk(beams=which, seed=4, block_name="weather")
        return WeatherChannel(name="weather", **kw).process(inputs | sub, chunk)["iq"]

    whole = draw(beams)
    for b in (0, 3):
        np.testing.assert_array_equal(draw(np.array([b]))[0], whole[b])
