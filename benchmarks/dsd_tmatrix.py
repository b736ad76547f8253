"""The Rayleigh spheroid model of blocks/weather/dsd.py against T-matrix amplitudes.

For the constrained-gamma distributions fitted to ZDR 0.5 to 3 dB (2.8 GHz, 10 C), the
distribution's ZDR, rho_hv, backscatter differential phase and KDP per Z from the module's
Rayleigh tables and from T-matrix amplitudes of the same drops (same sizes up to 8 mm, the same
Brandes et al. 2002 axis ratios, the same water permittivity), integrated over the same
distribution by pytmatrix's PSD integrator. pytmatrix itself ships only Fortran source (no
compiler here); its portable build ``pytmatrixc`` (PyPI, binary wheel) is used. Not a
dependency of the project: install it to run this.

    pip install pytmatrixc && PYTHONPATH=. python benchmarks/dsd_tmatrix.py
"""

from __future__ import annotations

import numpy as np
from pasim_blocks.weather import dsd
from pytmatrix import radar, tmatrix_aux
from pytmatrix.psd import GammaPSD, PSDIntegrator
from pytmatrix.tmatrix import Scatterer

FREQUENCY, TEMPERATURE = 2.8e9, 10.0


def main() -> None:
    wavelength_mm = 299_792_458.0 / FREQUENCY * 1e3
    eps = dsd.water_permittivity(FREQUENCY, TEMPERATURE)
    s = Scatterer(wavelength=wavelength_mm, m=complex(np.sqrt(eps)))
    s.Kw_sqr = 0.93
    s.psd_integrator = PSDIntegrator()
    # pytmatrix's axis ratio is horizontal over vertical.
    s.psd_integrator.axis_ratio_func = lambda d: 1.0 / float(dsd.axis_ratio(np.array(d)))
    s.psd_integrator.D_max = dsd.D_MAX_MM
    s.psd_integrator.num_points = 1024
    s.psd_integrator.geometries = (tmatrix_aux.geom_horiz_back, tmatrix_aux.geom_horiz_forw)
    s.psd_integrator.init_scatter_table(s)
    sizes = dsd.DropSizes.build(FREQUENCY, TEMPERATURE)
    print("| fitted to ZDR | Rayleigh: ZDR / rho_hv / delta / KDP per Z | T-matrix: the same |")
    print("| --- | --- | --- |")
    for zdr in (0.5, 1.0, 1.5, 2.0, 3.0):
        code = sizes.fit(np.array([zdr]))
        lam = float(sizes.lam[code[0]])
        mu = float(dsd.mu_of(np.array(lam)))
        s.psd = GammaPSD(D0=(3.67 + mu) / lam, Nw=8000.0, mu=mu, D_max=dsd.D_MAX_MM)
        s.set_geometry(tmatrix_aux.geom_horiz_back)
        t_zdr = 10 * np.log10(radar.Zdr(s))
        t_rho = radar.rho_hv(s)
        t_delta = np.rad2deg(radar.delta_hv(s))
        t_z = radar.refl(s)
        s.set_geometry(tmatrix_aux.geom_horiz_forw)
        t_kdp = radar.Kdp(s) / t_z * 1e4
        r_kdp = sizes.kdp[code[0]] / sizes.z_h[code[0]] * 1e4
        print(
            f"| {zdr} dB | {sizes.zdr_db[code[0]]:.3f} / {sizes.rho_hv(code)[0]:.5f} / "
            f"{sizes.delta_deg(code)[0]:.3f} / {r_kdp:.4f} | {t_zdr:.3f} / {t_rho:.5f} / "
            f"{t_delta:.3f} / {t_kdp:.4f} |"
        )
    print("(delta in deg; KDP in deg/km at 40 dBZ)")


if __name__ == "__main__":
    main()
