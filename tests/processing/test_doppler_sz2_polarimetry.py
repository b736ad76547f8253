"""SZ-2's polarimetric moments of both trips (processor.sz2, dual polarisation).

Series from the spectral method of Zrnic (1975) (``tests.reference.spectral_series``, no
code shared with the weather channel or the processor), V made from two independent
unit series a, b of the trip's spectrum as v = [rho a + sqrt(1 - rho^2) b] e^(j phi_DP) /
sqrt(Z_dr) (h = a), each trip multiplied by the SZ(8/64) phase of the pulse that made it;
64 pulses, PRT 1 ms, widths 2 m/s, strong trip at SNR 30 dB (ZDR 1 dB, rho_hv 0.98,
phi_DP 30 deg, 5 m/s), weak trip 10 m/s away with ZDR 3 dB, rho_hv 0.95, phi_DP 100 deg:

* at a 10 dB power ratio both trips' ZDR, rho_hv and phi_DP are recovered: mean within
  0.2 dB, 0.01 and 2 deg of what went in (2,000 gates; measured 0.00 / 0.06 dB, 0.001 /
  0.004, 0.2 / 0.2 deg), stds measured 0.52 / 1.12 dB, 0.013 / 0.040 and 3.7 / 7.7 deg;
* at 30 dB the weak trip (SNR 0 dB) has its polarimetric moments censored on every gate
  (below ``min_weak_snr_polarimetric_db``) through the processor block, while the strong
  trip's stay recovered.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.processing.sz2 import SZ2Processor, separate_trips
from pasim_blocks.timing import sz_code

from pasim_graph import Chunk
from tests.reference.spectral_series import spectral_series

WAVELENGTH_M = 299_792_458.0 / 2.8e9
PRT_S = 1e-3
M = 64
GATES = 2000
STRONG = {"power": 1e3, "v": 5.0, "ZDR": 1.0, "RHOHV": 0.98, "PHIDP": 30.0}
WEAK = {"v": 15.0, "ZDR": 3.0, "RHOHV": 0.95, "PHIDP": 100.0}


def trip(gen, power, v, zdr, rho, phi):
    a = spectral_series(gen, GATES, M, PRT_S, WAVELENGTH_M, [(1.0, v, 2.0)])
    b = spectral_series(gen, GATES, M, PRT_S, WAVELENGTH_M, [(1.0, v, 2.0)])
    h = np.sqrt(power) * a
    vv = np.sqrt(power / 10 ** (zdr / 10)) * (rho * a + np.sqrt(1 - rho**2) * b)
    return h, vv * np.exp(1j * np.deg2rad(phi))


def overlaid(ratio_db, seed=0):
    gen = np.random.default_rng(seed)
    psi = sz_code(8, 64)
    s = STRONG
    h1, v1 = trip(gen, s["power"], s["v"], s["ZDR"], s["RHOHV"], s["PHIDP"])
    w = WEAK
    h2, v2 = trip(gen, s["power"] / 10 ** (ratio_db / 10), w["v"], w["ZDR"], w["RHOHV"], w["PHIDP"])
    c1, c2 = np.exp(1j * psi), np.exp(1j * np.roll(psi, 1))

    def noise():
        return np.sqrt(0.5) * (
            gen.standard_normal((GATES, M)) + 1j * gen.standard_normal((GATES, M))
        )

    return psi, h1 * c1 + h2 * c2 + noise(), v1 * c1 + v2 * c2 + noise()


def test_both_trips_polarimetry_recovered():
    psi, xh, xv = overlaid(10.0)
    est = separate_trips(xh, psi, np.ones(GATES), PRT_S, WAVELENGTH_M, xv, np.ones(GATES))
    assert (est["strong"] == 1).all()
    for k, truth in (("1", STRONG), ("2", WEAK)):
        assert abs(np.mean(est[f"ZDR{k}"]) - truth["ZDR"]) < 0.2
        assert abs(np.mean(est[f"RHOHV{k}"]) - truth["RHOHV"]) < 0.01
        phi = np.angle(np.mean(np.exp(1j * np.deg2rad(est[f"PHIDP{k}"] - truth["PHIDP"]))))
        assert abs(np.rad2deg(phi)) < 2.0


@pytest.mark.parametrize("ratio_db", [10.0, 30.0])
def test_processor_censors_the_weak_trip_below_its_snr(ratio_db):
    psi, xh, xv = overlaid(ratio_db, seed=1)
    n_a = 600  # gates per unambiguous range (150 km of 250 m gates)
    rng = (np.arange(2 * n_a) + 0.5) * 249.827
    iq = np.zeros((1, rng.size, M, 2), np.complex64)
    iq[0, 100 : 100 + GATES // 4, :, 0] = xh[: GATES // 4]
    iq[0, 100 : 100 + GATES // 4, :, 1] = xv[: GATES // 4]
    cal = xr.Dataset(
        {"radar_constant_db": (("beam", "polarization"), np.zeros((1, 2)))},
        coords={"range": ("range", rng)},
        attrs={"wavelength_m": WAVELENGTH_M, "blind_range_m": 0.0, "calibration": "test"},
    )
    beams = xr.Dataset(
        {
            "prt": ("beam", [PRT_S]),
            "pulses": ((), M),
            "transmit_phase": (("beam", "pulse"), psi[None]),
        }
    )
    noise = np.ones((1, rng.size, 2))
    block = SZ2Processor(name="sz2")
    inputs = {"iq": iq, "noise_power": noise, "calibration": cal, "beams": beams}
    ds = block.process(inputs, Chunk(beams=np.arange(1)))["moments"]
    first = slice(100, 100 + GATES // 4)
    second = slice(100 + n_a, 100 + n_a + GATES // 4)
    assert np.isfinite(ds["ZDR"].values[0, first]).mean() > 0.99
    weak_kept = np.isfinite(ds["RHOHV"].values[0, second]).mean()
    if ratio_db == 10.0:
        assert weak_kept > 0.9
        assert abs(np.nanmean(ds["ZDR"].values[0, second]) - WEAK["ZDR"]) < 0.3
    else:
        assert weak_kept == 0.0
