"""Drop size distributions for the ``monte_carlo`` level: rain drops of their own sizes, shapes
and H and V scattering amplitudes, drawn from a gamma distribution fitted per cell to the
truth's Z and ZDR.

The model, with its sources (the formulas are written from the cited papers as the author
remembers them; no copy of the papers was available to check against):

- Distribution: the constrained gamma of Zhang, Vivekanandan & Brandes (2001, IEEE TGRS 39,
  830-841), N(D) = N0 D^mu exp(-Lambda D) on 0 < D <= 8 mm with mu = -0.016 Lambda^2 +
  1.213 Lambda - 1.957 (D in mm, Lambda in mm^-1). ZDR depends on the shape alone, so it fixes
  Lambda (the relation inverted numerically on a grid of Lambda), and Z then fixes N0: the
  constrained-gamma retrieval of Brandes, Zhang & Vivekanandan (2004, JAMC 43, 461-475).
  Beyond Lambda = 37.9 mm^-1, where the relation's mu peaks (21.0), mu is held there (an
  extension for drizzle, ZDR below about 0.2 dB). A truth ZDR outside the reachable range
  (about 0.01 to 4 dB) is clipped to it: rain drops cannot give a negative ZDR.
- Shape: equivolume diameter D, oblate spheroids with vertical symmetry axis (no canting),
  axis ratio of Brandes, Zhang & Vivekanandan (2002, JAM 41, 674-685), r = 0.9951 +
  0.02510 D - 0.03644 D^2 + 0.005303 D^3 - 0.0002492 D^4.
- Scattering: Rayleigh for spheroids (Bohren & Huffman 1983, sect. 5.3): the polarisability
  V (eps - 1) / (1 + L (eps - 1)) with the depolarisation factors L of an oblate spheroid,
  backscattering and forward amplitudes s = k^2 alpha / (4 pi). At S band (D / lambda < 0.08
  for D = 8 mm at 2.8 GHz) this is within a few percent of T-matrix amplitudes for drops
  under about 5 mm; it gives no resonance, so the backscatter differential phase is ~0.
- Water: the double-Debye permittivity of ITU-R P.840 (after Liebe, Hufford & Manabe 1991)
  at the carrier frequency and a temperature.

Reflectivity is Z = lambda^4 / (pi^5 |K_w|^2) int sigma N dD with the simulator's |K_w|^2 = 0.93,
so a sphere reduces to int D^6 N dD. KDP = (180 / pi) lambda Re int (f_h - f_v) N dD
(two-way PHIDP grows by 2 KDP per km). The drops are drawn from the reflectivity-weighted
distribution |s_h(D)|^2 N(D) (importance sampling: each drawn drop stands for the many drops of
its size in the cell, all with the same H power), so a cell's drops give back its Z exactly,
and ZDR, rho_hv and the backscatter phase are the drops' means of their V/H amplitude ratio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..signals import KW2, SPEED_OF_LIGHT

#: Largest drop diameter (mm): larger drops break up.
D_MAX_MM = 8.0
#: Lambda grid (mm^-1), log-spaced: from mu = -0.9 (the broadest distributions) to drizzle.
LAMBDA_RANGE = (0.9, 50.0)
#: Lambda where the constrained mu-Lambda relation peaks; mu is held beyond it.
LAMBDA_PEAK = 1.213 / 0.032


def water_permittivity(frequency_hz: float, temperature_c: float) -> complex:
    """Relative permittivity of liquid water, eps' + j eps'' (ITU-R P.840 double Debye).

    eps_0 = 77.66 + 103.3 (theta - 1), eps_1 = 5.48, eps_2 = 3.51, theta = 300 / T, principal
    and secondary relaxation frequencies f_p = 20.09 - 142 (theta - 1) + 294 (theta - 1)^2 GHz
    and f_s = 590 - 1500 (theta - 1) GHz. The imaginary part is returned positive (loss).
    """
    theta = 300.0 / (temperature_c + 273.15)
    e0 = 77.66 + 103.3 * (theta - 1)
    e1, e2 = 5.48, 3.51
    fp = 20.09 - 142.0 * (theta - 1) + 294.0 * (theta - 1) ** 2
    fs = 590.0 - 1500.0 * (theta - 1)
    f = frequency_hz / 1e9
    real = (e0 - e1) / (1 + (f / fp) ** 2) + (e1 - e2) / (1 + (f / fs) ** 2) + e2
    imag = f * (e0 - e1) / (fp * (1 + (f / fp) ** 2)) + f * (e1 - e2) / (fs * (1 + (f / fs) ** 2))
    return complex(real, imag)


def axis_ratio(d_mm: np.ndarray) -> np.ndarray:
    """Vertical over horizontal axis of a drop of equivolume diameter D (Brandes et al. 2002)."""
    d = np.asarray(d_mm, float)
    r = 0.9951 + 0.02510 * d - 0.03644 * d**2 + 0.005303 * d**3 - 0.0002492 * d**4
    return np.minimum(r, 1.0)


def depolarisation(ratio: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depolarisation factors (L_horizontal, L_vertical) of oblate spheroids (axis ratio <= 1).

    L_v = (1 + f^2) / f^2 (1 - arctan(f) / f) with f^2 = 1 / r^2 - 1, L_h = (1 - L_v) / 2;
    a sphere has 1/3 each (its series limit is used for r near 1).
    """
    r = np.asarray(ratio, float)
    f2 = np.maximum(1 / r**2 - 1, 0.0)
    f = np.sqrt(f2)
    small = f < 1e-3
    safe = np.where(small, 1.0, f)
    exact = (1 + f2) / np.where(small, 1.0, f2) * (1 - np.arctan(safe) / safe)
    l_v = np.where(small, 1 / 3 + 2 * f2 / 15, exact)
    return (1 - l_v) / 2, l_v


def amplitudes(
    d_mm: np.ndarray, wavelength_m: float, eps: complex
) -> tuple[np.ndarray, np.ndarray]:
    """Rayleigh scattering amplitudes (m) of drops for H and V polarisation at horizontal
    incidence: s = k^2 V (eps - 1) / (4 pi (1 + L (eps - 1))); backscatter = forward.

    Returned in the radar engineering convention (time factor e^{j omega t}: the complex
    conjugate of the physics convention's), in which PHIDP grows along the path as the
    simulator's V series carries it.
    """
    d_m = np.asarray(d_mm, float) * 1e-3
    l_h, l_v = depolarisation(axis_ratio(d_mm))
    k = 2 * np.pi / wavelength_m
    volume = np.pi * d_m**3 / 6
    s = [
        np.conj(k**2 * volume * (eps - 1) / (4 * np.pi * (1 + lj * (eps - 1)))) for lj in (l_h, l_v)
    ]
    return s[0], s[1]


def mu_of(lam: np.ndarray) -> np.ndarray:
    """Shape parameter of the constrained gamma (Zhang et al. 2001), held beyond its peak."""
    x = np.minimum(np.asarray(lam, float), LAMBDA_PEAK)
    return -0.016 * x**2 + 1.213 * x - 1.957


@dataclass(frozen=True)
class DropSizes:
    """Tables of the constrained-gamma family at one wavelength and temperature.

    For each Lambda of the grid (index: the cell's ``code``) with N0 = 1 m^-3 mm^-1-mu: the
    reflectivities Z_h, Z_v (mm^6 m^-3), E_z[q], E_z[|q|^2] of the V/H amplitude ratio q of
    a drop under the reflectivity-weighted distribution, KDP (deg/km), and the
    reflectivity-weighted distribution's quantiles of D (mm) for drawing drops.
    """

    wavelength_m: float
    lam: np.ndarray
    z_h: np.ndarray
    zdr_db: np.ndarray
    mean_q: np.ndarray
    mean_q2: np.ndarray
    kdp: np.ndarray
    quantiles: np.ndarray
    d_mm: np.ndarray
    q: np.ndarray

    @classmethod
    def build(
        cls, frequency_hz: float, temperature_c: float, n_lambda: int = 1024, n_d: int = 4000
    ) -> DropSizes:
        lam_m = SPEED_OF_LIGHT / frequency_hz
        eps = water_permittivity(frequency_hz, temperature_c)
        d = np.linspace(D_MAX_MM / n_d, D_MAX_MM, n_d)
        step = d[1] - d[0]
        s_h, s_v = amplitudes(d, lam_m, eps)
        q = s_v / s_h
        lam = np.geomspace(*LAMBDA_RANGE, n_lambda)
        mu = mu_of(lam)
        # N(D) dD per N0 = 1, in m^-3 (D in mm): Lambda x D.
        n = d[None, :] ** mu[:, None] * np.exp(-lam[:, None] * d[None, :]) * step
        to_z = wavelength_factor(lam_m)
        w = np.abs(s_h) ** 2 * n  # reflectivity weight of each size
        z_h = to_z * w.sum(axis=1)
        z_v = to_z * (np.abs(s_v) ** 2 * n).sum(axis=1)
        total = w.sum(axis=1)
        mean_q = (w * q).sum(axis=1) / total
        mean_q2 = (w * np.abs(q) ** 2).sum(axis=1) / total
        # deg/km: (180/pi) lambda Re sum (f_h - f_v) N, N in m^-3, x 1e3 m/km.
        kdp = (180 / np.pi) * lam_m * ((s_h - s_v).real * n).sum(axis=1) * 1e3
        cdf = np.cumsum(w, axis=1)
        cdf = np.concatenate([np.zeros((lam.size, 1)), cdf / cdf[:, -1:]], axis=1)
        edges = np.concatenate([[0.0], d + step / 2])
        probs = np.linspace(0.0, 1.0, 1025)
        quantiles = np.stack([np.interp(probs, c, edges) for c in cdf])
        return cls(lam_m, lam, z_h, 10 * np.log10(z_h / z_v), mean_q, mean_q2, kdp, quantiles, d, q)

    def fit(self, zdr_db: np.ndarray) -> np.ndarray:
        """The grid index (code) whose ZDR is nearest each given ZDR (clipped to the range)."""
        order = self.zdr_db[::-1]  # ZDR falls as Lambda grows: increasing in reverse
        x = np.clip(np.asarray(zdr_db, float), order[0], order[-1])
        i = np.clip(np.searchsorted(order, x), 1, order.size - 1)
        nearer = np.where(np.abs(order[i - 1] - x) <= np.abs(order[i] - x), i - 1, i)
        return (self.lam.size - 1 - nearer).astype(np.int32)

    def rho_hv(self, code: np.ndarray) -> np.ndarray:
        """Copolar correlation of the fitted distributions: |E_z q| / sqrt(E_z |q|^2)."""
        return np.abs(self.mean_q[code]) / np.sqrt(self.mean_q2[code])

    def delta_deg(self, code: np.ndarray) -> np.ndarray:
        """Backscatter differential phase (deg) of the fitted distributions."""
        return np.rad2deg(np.angle(self.mean_q[code]))

    def kdp_deg_per_km(self, code: np.ndarray, dbz: np.ndarray) -> np.ndarray:
        """KDP of the distribution with the given Z: N0 = Z / Z_h(N0 = 1)."""
        return self.kdp[code] * 10 ** (dbz / 10) / self.z_h[code]

    def draw(
        self, code: np.ndarray, gen: np.random.Generator, drops: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Drops of cells (cell x drop): diameters (mm) from the reflectivity-weighted
        distribution, and their V/H amplitude ratios scaled to unit mean power
        (q / sqrt(E_z |q|^2)), so each cell's V series has unit power like its H."""
        u = gen.uniform(0.0, 1.0, (code.size, drops)) * (self.quantiles.shape[1] - 1)
        i = np.minimum(u.astype(np.int64), self.quantiles.shape[1] - 2)
        rows = self.quantiles[code]
        lo = np.take_along_axis(rows, i, axis=1)
        hi = np.take_along_axis(rows, i + 1, axis=1)
        d = lo + (u - i) * (hi - lo)
        q = np.interp(d, self.d_mm, self.q.real) + 1j * np.interp(d, self.d_mm, self.q.imag)
        return d, q / np.sqrt(self.mean_q2[code])[:, None]


def wavelength_factor(wavelength_m: float) -> float:
    """Z (mm^6 m^-3) per sum of |s|^2 N (m^2 m^-3): 4 pi lambda^4 / (pi^5 |K_w|^2) x 1e18."""
    return 4 * np.pi * wavelength_m**4 / (np.pi**5 * KW2) * 1e18


def propagation_phase(
    kdp_deg_per_km: np.ndarray, echo: np.ndarray, step_m: float, start_deg: np.ndarray
) -> np.ndarray:
    """Two-way differential propagation phase at each cell's centre (deg), radial x gate:
    ``start_deg`` (the radial's offset) + 2 x the KDP integrated from the first gate."""
    k = np.where(echo, kdp_deg_per_km, 0.0) * step_m / 1e3
    return start_deg[:, None] + 2 * (np.cumsum(k, axis=1) - k / 2)


def fit_drop_sizes(
    sizes: DropSizes, field: dict[str, np.ndarray], dbz: np.ndarray, echo: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """Fit each cell's gamma distribution to its Z and ZDR (:class:`DropSizes`) and replace
    ``field``'s ZDR, RHOHV and PHIDP by the drops'. PHIDP: the sweep's system offset, plus
    twice the KDP integrated along the radial, plus the backscatter phase; the offset is the
    circular mean over the echo cells of the truth's PHIDP less the drops' propagation
    phase. Returns the cells' grid codes and the propagation part of PHIDP."""
    codes = sizes.fit(field["ZDR"])
    kdp = sizes.kdp_deg_per_km(codes, np.where(echo, np.nan_to_num(dbz, nan=0.0), -300.0))
    # One system offset for the sweep, the circular mean of the truth's PHIDP less the drops'
    # propagation phase over the echo cells: per radial it would be noisy, and radials of
    # different offsets in one beam would decorrelate H and V.
    propagation = propagation_phase(kdp, echo, step, np.zeros(echo.shape[0]))
    diff = np.deg2rad(field["PHIDP"][echo] - propagation[echo])
    offset = float(np.rad2deg(np.angle(np.mean(np.exp(1j * diff))))) if diff.size else 0.0
    propagation += offset
    field["ZDR"] = sizes.zdr_db[codes]
    field["RHOHV"] = sizes.rho_hv(codes)
    field["PHIDP"] = propagation + sizes.delta_deg(codes)
    return codes, propagation
