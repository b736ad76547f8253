"""Theoretical bias and standard deviation of the pulse-pair estimates of ``blocks/ppp.py``.

The reference against which the simulator's moment statistics are validated. The signal model
is a uniform (stationary) dual-polarisation weather echo with a Gaussian Doppler spectrum, in
white noise of the same power in both channels:

* H channel: ``E[h_{m+k} h_m^*] = S_H rho(k) exp(-j omega k) + N delta_k``, with
  ``rho(k) = exp(-8 (pi w k T / lambda)^2)`` (Gaussian spectrum of width ``w``) and
  ``omega = 4 pi v T / lambda`` (positive velocity = away = negative lag-1 phase, as NEXRAD);
* V channel: the same with ``S_V = S_H / Z_DR``, so its SNR is lower by Z_DR;
* H-V: ``E[v_{m+k} h_m^*] = sqrt(S_H S_V) rho_hv exp(j phi_DP) rho(k) exp(-j omega k)``.

The estimators (``ppp.pulse_pair``) are smooth functions ``g`` of four sample correlations of
one dwell of ``M`` pulses: the lag-0 powers ``P_H``, ``P_V`` (means over ``M``), the lag-0 H-V
correlation ``R_hv`` (mean of ``h^* v`` over ``M``) and the H lag-1 correlation ``R_1`` (mean
of ``h_m^* h_{m+1}`` over ``M - 1``). Each is a sum of products of jointly circular Gaussian
samples, so its exact mean and covariance follow from Isserlis' theorem with the full
``M x M`` pulse-to-pulse correlation (no independent-sample approximation); with ``c(d)`` the
number of index pairs at separation ``d`` the covariances reduce to sums over lags.

:func:`estimator_statistics` (the primary reference) applies the delta method to them: the
standard deviation to first order, ``sqrt(grad g' C grad g)``, and the bias to second order,
``tr(H_g C) / 2``. The first-order variance is the perturbation result of Doviak & Zrnic
(1993) and Zrnic (1977) for power and velocity, and of Melnikov & Zrnic (2004, 2007) for the
polarimetric moments, evaluated here without their large-M approximation; the second-order bias
is the finite-dwell bias (e.g. of dB power, Z_DR, rho_hv and width).

Assumptions, and where they fail
--------------------------------
* Gaussian spectrum, uniform scatterers, white noise of known power (the estimator subtracts
  exactly the true noise power); the autocorrelation ``rho(k)`` above is sampled as is, so the
  spectrum's own aliasing (widths approaching the Nyquist interval) is not modelled.
* Velocities inside +-Nyquist: the velocity "bias" is about the true value, no unfolding.
* The estimator's masking (S <= 0 -> NaN) and its clipping of a negative width argument to
  zero are ignored: they are rare at the SNRs of interest (10 dB and more) *except* for the
  width of narrow spectra, see below.
* The delta method is an expansion in the relative fluctuation of the sample correlations,
  i.e. in ``1 / M_I`` with ``M_I`` the number of independent samples
  (:func:`independent_samples`; ``2 sqrt(pi) sigma_vn M`` for large M, ``sigma_vn =
  2 w T / lambda``). Against a Monte Carlo of the estimator (20,000 dwells, PRT 1 ms, S band,
  M = 32 and 128, widths 2 and 4 m/s, SNR 10 and 30 dB, rho_hv 0.9 and 0.98) the first-order
  std of DBZH and VRADH is within 3.5 % everywhere (``M_I`` down to 4.6); the polarimetric
  stds come out low by up to about ``1 / M_I`` (worst for rho_hv near 1: rho_hv's std is
  about 25 % low at ``M_I`` = 4.6, 5 % at 17, 3 % at 34; Z_DR and phi_DP about half that).
* The width is the delicate one: ``w ~ sqrt(L)``, ``L = ln(S / |R_1|)``, and for narrow
  spectra L is small (0.028 for 2 m/s at PRT 1 ms, S band) while its fluctuation is not, so
  the expansion of the square root fails when ``std(L) / L`` (:func:`width_log_ratio_cv`) is
  not small, and the estimate is then often clipped to zero. Below about 0.35 the delta-method
  width std is within a few percent; at 0.5 it is 14 % low and its bias is off (at ratios
  near 1 the std can agree again, by accident, while the bias is 50 % off).
* The velocity and phi_DP biases are zero: the spectrum is symmetric about its mean, so the
  phase errors of R_1 and R_hv are symmetric.

Where these limits bite, the reference is a Monte Carlo of the estimator itself on ideal
Gaussian I/Q, :func:`monte_carlo_statistics`.

Closed forms for cross-checking (large-M, Gaussian spectrum), with their sources, are in
:func:`closed_form_statistics` and the functions it calls.

Units: DBZH and ZDR in dB, VRADH and WRADH in m/s, RHOHV dimensionless, PHIDP in degrees.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: The six moments, in the order of the volume's fields.
MOMENTS = ("DBZH", "VRADH", "WRADH", "ZDR", "RHOHV", "PHIDP")

DB = 10 / np.log(10)  # dB per neper of power: 4.343

# The sample correlations of one dwell: (conjugated channel, other channel, lag); index 0 = H.
_CORRELATIONS = {"P_H": (0, 0, 0), "P_V": (1, 1, 0), "R_hv": (0, 1, 0), "R_1": (0, 0, 1)}
# Real components of the delta method's vector t: (correlation, part).
_COMPONENTS = (("P_H", "re"), ("P_V", "re"), ("R_hv", "re"), ("R_hv", "im"))
_COMPONENTS += (("R_1", "re"), ("R_1", "im"))
# Index of each component in t.
I_PH, I_PV, I_RHV_RE, I_RHV_IM, I_R1_RE, I_R1_IM = range(6)


def _gaussian_decay(width_ms, prt_s, wavelength_m):
    """The constant ``a`` of ``rho(k) = exp(-a k^2)``: ``8 (pi w T / lambda)^2``."""
    return 8 * (np.pi * np.asarray(width_ms, float) * prt_s / wavelength_m) ** 2


def _normalised_width(width_ms, prt_s, wavelength_m):
    """``sigma_vn = w / (2 v_a) = 2 w T / lambda``, the width in units of the Nyquist interval."""
    return 2 * np.asarray(width_ms, float) * np.asarray(prt_s, float) / wavelength_m


def sample_correlation_moments(
    pulses,
    prt_s,
    wavelength_m,
    width_ms,
    velocity_ms,
    signal_h,
    signal_v,
    noise_h,
    noise_v,
    rho_hv,
    phidp_deg,
) -> tuple[np.ndarray, np.ndarray]:
    """Exact mean and covariance of the sample correlations of one dwell (Isserlis).

    All arguments broadcast together (``pulses`` may vary too).

    Parameters
    ----------
    pulses : int or array of int
        Number of pulses ``M`` in the dwell (at least 2).
    prt_s : float or array
        Pulse repetition time ``T`` (s).
    wavelength_m : float or array
        Wavelength ``lambda`` (m).
    width_ms : float or array
        Spectrum width (m/s).
    velocity_ms : float or array
        Mean radial velocity (m/s), positive away from the radar.
    signal_h, signal_v : float or array
        Signal powers in H and V (any unit, the same as the noise).
    noise_h, noise_v : float or array
        White-noise powers in H and V.
    rho_hv : float or array
        Copolar correlation coefficient (0 to 1).
    phidp_deg : float or array
        Differential phase (deg).

    Returns
    -------
    mean : ndarray, shape (..., 6)
        Means of ``t = (P_H, P_V, Re R_hv, Im R_hv, Re R_1, Im R_1)``.
    cov : ndarray, shape (..., 6, 6)
        Their covariance matrix.

    Notes
    -----
    A sample correlation is ``A = (1/L_A) sum_m x_m^* y_{m+p}`` (``L_A = M - p`` terms). With
    ``R_ab(k) = E[a_{i+k} b_i^*]`` and ``c(d)`` the number of ``(m, n)`` with ``n - m = d``,
    Isserlis' theorem for circular Gaussian samples gives

    * ``E[(A - EA)(B - EB)^*] = sum_d c(d) R_yw(p - q - d) R_ux(d) / (L_A L_B)``,
    * ``E[(A - EA)(B - EB)]   = sum_d c(d) R_yu(p - d) R_wx(d + q) / (L_A L_B)``,

    from which the covariances of real and imaginary parts follow.
    """
    args = np.broadcast_arrays(
        *(
            np.asarray(x, float)
            for x in (
                pulses,
                prt_s,
                wavelength_m,
                width_ms,
                velocity_ms,
                signal_h,
                signal_v,
                noise_h,
                noise_v,
                rho_hv,
                phidp_deg,
            )
        )
    )
    m, prt, lam, width, vel, s_h, s_v, n_h, n_v, rho, phi = (x[..., None] for x in args)
    if np.any(m < 2) or np.any(m != np.round(m)):
        raise ValueError("pulses must be whole numbers, at least 2")
    m_max = int(np.max(m))
    d = np.arange(-(m_max - 1), m_max)  # trailing axis: pulse separations

    a = _gaussian_decay(width, prt, lam)
    omega = 4 * np.pi * vel * prt / lam
    cross = np.sqrt(s_h * s_v) * rho
    phase = np.exp(1j * np.deg2rad(phi))
    power = (s_h, s_v)
    noise = (n_h, n_v)

    def corr(a_ch: int, b_ch: int, k: np.ndarray) -> np.ndarray:
        """R_ab(k) = E[a_{i+k} b_i^*] for channels 0 = H, 1 = V."""
        base = np.exp(-a * k**2 - 1j * omega * k)
        if a_ch == b_ch:
            return power[a_ch] * base + noise[a_ch] * (k == 0)
        return cross * base * (phase if a_ch == 1 else np.conj(phase))

    names = list(_CORRELATIONS)
    means = {}
    for name, (x, y, p) in _CORRELATIONS.items():
        means[name] = corr(y, x, np.array(p))[..., 0]
    cov_c, pseudo = {}, {}
    for i, na in enumerate(names):
        x, y, p = _CORRELATIONS[na]
        for nb in names[i:]:
            u, w, q = _CORRELATIONS[nb]
            la, lb = m - p, m - q
            count = np.clip(np.minimum(la, lb - d) - np.maximum(0, -d), 0, None)
            scale = 1 / (la * lb)
            c = np.sum(count * corr(y, w, p - q - d) * corr(u, x, d), axis=-1)
            ps = np.sum(count * corr(y, u, p - d) * corr(w, x, d + q), axis=-1)
            cov_c[na, nb] = c * scale[..., 0]
            pseudo[na, nb] = ps * scale[..., 0]
            # Swapped order: E[B A^*] = conj(E[A B^*]), E[B A] = E[A B].
            cov_c[nb, na] = np.conj(cov_c[na, nb])
            pseudo[nb, na] = pseudo[na, nb]

    shape = args[0].shape
    mean = np.empty((*shape, 6))
    cov = np.empty((*shape, 6, 6))
    for i, (na, pa) in enumerate(_COMPONENTS):
        mean[..., i] = means[na].real if pa == "re" else means[na].imag
        for j, (nb, pb) in enumerate(_COMPONENTS):
            c, ps = cov_c[na, nb], pseudo[na, nb]
            if pa == "re" and pb == "re":
                v = (c + ps).real / 2
            elif pa == "re":
                v = (ps - c).imag / 2
            elif pb == "re":
                v = (ps + c).imag / 2
            else:
                v = (c - ps).real / 2
            cov[..., i, j] = v
    return mean, cov


# ---- delta method ---------------------------------------------------------------------------

# A function of t with its gradient and Hessian there: (value, grad (..., 6), hess (..., 6, 6)).
_Jet = tuple[np.ndarray, np.ndarray, np.ndarray]


def _zeros(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(t.shape), np.zeros((*t.shape, 6))


def _power(t: np.ndarray, i: int, noise: np.ndarray) -> _Jet:
    """t_i - noise: a noise-corrected power."""
    g, h = _zeros(t)
    g[..., i] = 1.0
    return t[..., i] - noise, g, h


def _log_power(t: np.ndarray, i: int, noise: np.ndarray) -> _Jet:
    """ln(t_i - noise): the log of a noise-corrected power."""
    s = t[..., i] - noise
    g, h = _zeros(t)
    g[..., i] = 1 / s
    h[..., i, i] = -1 / s**2
    return np.log(s), g, h


def _log_abs(t: np.ndarray, i: int, j: int) -> _Jet:
    """ln |t_i + j t_j|."""
    x, y = t[..., i], t[..., j]
    r2 = x**2 + y**2
    g, h = _zeros(t)
    g[..., i], g[..., j] = x / r2, y / r2
    h[..., i, i] = (y**2 - x**2) / r2**2
    h[..., j, j] = -h[..., i, i]
    h[..., i, j] = h[..., j, i] = -2 * x * y / r2**2
    return 0.5 * np.log(r2), g, h


def _arg(t: np.ndarray, i: int, j: int) -> _Jet:
    """arg(t_i + j t_j) (rad)."""
    x, y = t[..., i], t[..., j]
    r2 = x**2 + y**2
    g, h = _zeros(t)
    g[..., i], g[..., j] = -y / r2, x / r2
    h[..., i, i] = 2 * x * y / r2**2
    h[..., j, j] = -h[..., i, i]
    h[..., i, j] = h[..., j, i] = (y**2 - x**2) / r2**2
    return np.arctan2(y, x), g, h


def _lin(*terms: tuple[float, _Jet]) -> _Jet:
    """A linear combination of jets."""
    out = [0.0, 0.0, 0.0]
    for c, jet in terms:
        c = np.asarray(c, float)  # scalar, or one coefficient per parameter set
        for k in range(3):
            out[k] = out[k] + c[(...,) + (None,) * k] * jet[k]
    return out[0], out[1], out[2]


def _compose(jet: _Jet, f: Callable, df: Callable, d2f: Callable) -> _Jet:
    """f(jet) by the chain rule."""
    v, g, h = jet
    f1, f2 = df(v)[..., None], d2f(v)[..., None, None]
    return f(v), f1 * g, f1[..., None] * h + f2 * g[..., :, None] * g[..., None, :]


def estimator_jets(
    t: np.ndarray, noise_h, noise_v, prt_s, wavelength_m
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Each estimate of ``ppp.pulse_pair`` as a function of ``t``, with gradient and Hessian.

    Parameters
    ----------
    t : ndarray, shape (..., 6)
        ``(P_H, P_V, Re R_hv, Im R_hv, Re R_1, Im R_1)`` at which to evaluate.
    noise_h, noise_v, prt_s, wavelength_m : float or array
        Noise powers subtracted by the estimator, PRT (s) and wavelength (m).

    Returns
    -------
    dict
        ``name -> (value, gradient, Hessian)`` for S_H, S_V (linear), DBZH (dB of S_H, without
        the radar constant), VRADH, WRADH, ZDR, RHOHV and PHIDP (deg, not wrapped).
    """
    t = np.asarray(t, float)
    n_h = np.broadcast_to(noise_h, t.shape[:-1])
    n_v = np.broadcast_to(noise_v, t.shape[:-1])
    k_vel = wavelength_m / (4 * np.pi * np.asarray(prt_s, float))
    k_width = wavelength_m / (2 * np.sqrt(2) * np.pi * np.asarray(prt_s, float))
    ln_h, ln_v = _log_power(t, I_PH, n_h), _log_power(t, I_PV, n_v)
    ln_rhv, ln_r1 = _log_abs(t, I_RHV_RE, I_RHV_IM), _log_abs(t, I_R1_RE, I_R1_IM)
    ratio = _lin((1.0, ln_h), (-1.0, ln_r1))  # ln(S_H / |R_1|)
    return {
        "S_H": _power(t, I_PH, n_h),
        "S_V": _power(t, I_PV, n_v),
        "DBZH": _lin((DB, ln_h)),
        "ZDR": _lin((DB, ln_h), (-DB, ln_v)),
        "RHOHV": _compose(_lin((1.0, ln_rhv), (-0.5, ln_h), (-0.5, ln_v)), np.exp, np.exp, np.exp),
        "PHIDP": _lin((np.rad2deg(1.0), _arg(t, I_RHV_RE, I_RHV_IM))),
        "VRADH": _lin((-k_vel, _arg(t, I_R1_RE, I_R1_IM))),
        "WRADH": _compose(
            ratio,
            lambda x: k_width * np.sqrt(x),
            lambda x: k_width / (2 * np.sqrt(x)),
            lambda x: -k_width / (4 * x**1.5),
        ),
    }


def pulse_pair_statistics(
    pulses,
    prt_s,
    wavelength_m,
    width_ms,
    velocity_ms,
    signal_h,
    signal_v,
    noise_h,
    noise_v,
    rho_hv,
    phidp_deg,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Expected value (second order) and standard deviation (first order) of every estimate.

    The general form of :func:`estimator_statistics`: powers and noise given separately in H
    and V (any common unit). Arguments as in :func:`sample_correlation_moments`.

    Returns
    -------
    dict
        ``name -> (mean, std)`` for S_H, S_V (linear power), DBZH (``10 log10`` of the H
        signal power), VRADH, WRADH, ZDR, RHOHV, PHIDP (deg, in [0, 360) as estimated).
    """
    mean, cov = sample_correlation_moments(
        pulses,
        prt_s,
        wavelength_m,
        width_ms,
        velocity_ms,
        signal_h,
        signal_v,
        noise_h,
        noise_v,
        rho_hv,
        phidp_deg,
    )
    shape = mean.shape[:-1]
    jets = estimator_jets(
        mean,
        np.broadcast_to(noise_h, shape),
        np.broadcast_to(noise_v, shape),
        np.broadcast_to(prt_s, shape),
        np.broadcast_to(wavelength_m, shape),
    )
    out = {}
    for name, (value, grad, hess) in jets.items():
        bias = 0.5 * np.einsum("...ij,...ij->...", hess, cov)
        var = np.einsum("...i,...ij,...j->...", grad, cov, grad)
        out[name] = (value + bias, np.sqrt(np.maximum(var, 0.0)))  # rounding near rho = 1
    out["PHIDP"] = (np.mod(out["PHIDP"][0], 360.0), out["PHIDP"][1])  # as the estimator reports
    return out


def _normalised_powers(snr_db, zdr_db):
    """S_H = 1, S_V = 1 / Z_DR, N = 1 / SNR_H in both channels."""
    s_v = 10 ** (-np.asarray(zdr_db, float) / 10)
    noise = 10 ** (-np.asarray(snr_db, float) / 10)
    return 1.0, s_v, noise


def estimator_statistics(
    pulses,
    prt_s,
    wavelength_m,
    width_ms,
    velocity_ms,
    snr_db,
    zdr_db,
    rho_hv,
    phidp_deg,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Theoretical bias and standard deviation of the six pulse-pair moments (delta method).

    Exact Isserlis covariances of the sample correlations of a dwell (the full M x M
    pulse-to-pulse correlation of a Gaussian spectrum in white noise), then the delta method:
    standard deviation to first order, bias to second order. See the module docstring for the
    assumptions and for where the expansion loses accuracy: polarimetric stds low by up to
    ``1 / M_I`` (:func:`independent_samples`), and the width of narrow spectra at low SNR or
    short dwells (:func:`width_log_ratio_cv`); there, use :func:`monte_carlo_statistics`.
    All arguments broadcast together.

    Parameters
    ----------
    pulses : int or array of int
        Pulses per dwell ``M``.
    prt_s : float or array
        Pulse repetition time (s).
    wavelength_m : float or array
        Wavelength (m).
    width_ms : float or array
        Spectrum width (m/s), > 0.
    velocity_ms : float or array
        Mean radial velocity (m/s, positive away), inside +-Nyquist.
    snr_db : float or array
        Signal-to-noise ratio of the H channel (dB). V has the same noise power, so its SNR is
        ``snr_db - zdr_db``.
    zdr_db : float or array
        Differential reflectivity (dB).
    rho_hv : float or array
        Copolar correlation coefficient.
    phidp_deg : float or array
        Differential phase (deg).

    Returns
    -------
    dict
        ``name -> (bias, std)`` for DBZH (dB), VRADH (m/s), WRADH (m/s), ZDR (dB), RHOHV and
        PHIDP (deg). The bias is the expected estimate minus the truth; DBZH's is that of the
        dB power, which does not depend on the reflectivity or the radar constant.

    Examples
    --------
    >>> stats = estimator_statistics(64, 1e-3, 0.107, 4.0, 5.0, 20.0, 1.0, 0.98, 30.0)
    >>> bias, std = stats["VRADH"]
    """
    s_h, s_v, noise = _normalised_powers(snr_db, zdr_db)
    stats = pulse_pair_statistics(
        pulses,
        prt_s,
        wavelength_m,
        width_ms,
        velocity_ms,
        s_h,
        s_v,
        noise,
        noise,
        rho_hv,
        phidp_deg,
    )
    truth = {
        "DBZH": 0.0,
        "VRADH": velocity_ms,
        "WRADH": width_ms,
        "ZDR": zdr_db,
        "RHOHV": rho_hv,
        "PHIDP": phidp_deg,
    }
    out = {k: (stats[k][0] - np.asarray(truth[k], float), stats[k][1]) for k in MOMENTS}
    out["PHIDP"] = ((out["PHIDP"][0] + 180.0) % 360.0 - 180.0, out["PHIDP"][1])
    return out


def independent_samples(pulses, prt_s, wavelength_m, width_ms) -> np.ndarray:
    """Number of independent samples of the lag-0 power, ``M_I = M / sum_{|k|<M} (1 - |k|/M)
    rho(k)^2``, for a Gaussian spectrum (Doviak & Zrnic 1993, sect. 6.3); about
    ``2 sqrt(pi) sigma_vn M`` when ``sigma_vn M >> 1``. The delta method's relative error is of
    order ``1 / M_I``. Arguments as in :func:`estimator_statistics`.
    """
    m = np.asarray(pulses, float)
    return m / _independent_sample_sum(pulses, prt_s, wavelength_m, width_ms, large_m=False)


def width_log_ratio_cv(
    pulses, prt_s, wavelength_m, width_ms, velocity_ms, snr_db, zdr_db, rho_hv, phidp_deg
) -> np.ndarray:
    """Relative fluctuation std(L) / L of ``L = ln(S_H / |R_1|)``, of which the width is a root.

    The delta-method width statistics hold while this is small: within a few percent below
    about 0.35; beyond, the square root's curvature and the estimator's clipping of ``L < 0``
    to zero width dominate and a Monte Carlo of the estimator is the reference. Arguments as
    in :func:`estimator_statistics`.
    """
    s_h, s_v, noise = _normalised_powers(snr_db, zdr_db)
    mean, cov = sample_correlation_moments(
        pulses,
        prt_s,
        wavelength_m,
        width_ms,
        velocity_ms,
        s_h,
        s_v,
        noise,
        noise,
        rho_hv,
        phidp_deg,
    )
    n = np.broadcast_to(noise, mean.shape[:-1])
    value, grad, _ = _lin((1.0, _log_power(mean, I_PH, n)), (-1.0, _log_abs(mean, 4, 5)))
    return np.sqrt(np.einsum("...i,...ij,...j->...", grad, cov, grad)) / value


# ---- closed forms from the literature (cross-checks) ------------------------------------------


def _independent_sample_sum(pulses, prt_s, wavelength_m, width_ms, large_m: bool):
    """``sum_{|k|<M} (1 - |k|/M) rho(k)^2``, or its large-M Gaussian value
    ``1 / (2 sqrt(pi) sigma_vn)`` (so that ``M_I = M / sum``)."""
    if large_m:
        return 1 / (2 * np.sqrt(np.pi) * _normalised_width(width_ms, prt_s, wavelength_m))
    m = np.asarray(pulses, float)[..., None]
    k = np.arange(-(int(np.max(m)) - 1), int(np.max(m)))
    a = _gaussian_decay(width_ms, prt_s, wavelength_m)[..., None]
    weight = np.clip(1 - np.abs(k) / m, 0, None)
    return np.sum(weight * np.exp(-2 * a * k**2), axis=-1)


def power_statistics_dz(pulses, prt_s, wavelength_m, width_ms, snr_db, large_m=True):
    """Bias and std (dB) of the noise-corrected power estimate in dB.

    Doviak & Zrnic (1993), *Doppler Radar and Weather Observations*, 2nd ed., sect. 6.3 (the
    variance of the sample power of correlated Gaussian samples in white noise):
    ``var(P) = (S^2 / M) [sum_{|k|<M} (1 - |k|/M) rho(k)^2 + 2 N/S + (N/S)^2]``, and for a
    Gaussian spectrum with ``sigma_vn M >> 1`` the sum is ``1 / (2 sqrt(pi) sigma_vn)``
    (``M_I = 2 sqrt(pi) sigma_vn M`` independent samples). In dB to first order,
    ``std = 4.343 sqrt(var(P)) / S``; the second-order bias of ``10 log10`` is
    ``-4.343 var(P) / (2 S^2)``.

    Parameters
    ----------
    large_m : bool
        Use the large-M Gaussian sum (the textbook form) rather than the exact finite sum.

    Returns
    -------
    bias, std : ndarray (dB)
    """
    n = 10 ** (-np.asarray(snr_db, float) / 10)
    s = _independent_sample_sum(pulses, prt_s, wavelength_m, width_ms, large_m)
    var = (s + 2 * n + n**2) / np.asarray(pulses, float)
    return -DB * var / 2, DB * np.sqrt(var)


def velocity_std_zrnic(pulses, prt_s, wavelength_m, width_ms, snr_db, large_m=True):
    """Standard deviation (m/s) of the pulse-pair velocity.

    Zrnic (1977), "Spectral moment estimates from correlated pulse pairs", IEEE Trans. Aerosp.
    Electron. Syst. 13, 344-354; Doviak & Zrnic (1993) sect. 6.4 (eq. 6.21), Gaussian spectrum:
    ``var(v) = lambda^2 / (32 pi^2 M T^2 rho(1)^2) {(1 - rho(1)^2) sum_{|k|<M} (1 - |k|/M)
    rho(k)^2 + (N/S)^2 + 2 (N/S) (1 - rho(2))}`` with ``M`` the number of pulse pairs
    (``pulses - 1`` here). With ``large_m`` the sum is ``1 / (2 sqrt(pi) sigma_vn)``. In the
    narrow-spectrum, high-SNR limit this becomes ``var(v) = sigma_v lambda / (8 M T
    sqrt(pi))`` (D&Z sect. 6.4): :func:`velocity_std_narrow`.
    """
    pairs = np.asarray(pulses, float) - 1
    a = _gaussian_decay(width_ms, prt_s, wavelength_m)
    rho1, rho2 = np.exp(-a), np.exp(-4 * a)
    n = 10 ** (-np.asarray(snr_db, float) / 10)
    s = _independent_sample_sum(pairs, prt_s, wavelength_m, width_ms, large_m)
    braces = (1 - rho1**2) * s + n**2 + 2 * n * (1 - rho2)
    var = wavelength_m**2 / (32 * np.pi**2 * pairs * np.asarray(prt_s) ** 2 * rho1**2) * braces
    return np.sqrt(var)


def velocity_std_narrow(pulses, prt_s, wavelength_m, width_ms):
    """``sqrt(sigma_v lambda / (8 M T sqrt(pi)))``: Doviak & Zrnic (1993) sect. 6.4, the
    pulse-pair velocity std for a narrow Gaussian spectrum (``sigma_vn`` small) at high SNR
    and large M (``M`` = ``pulses - 1`` pairs); the limit of :func:`velocity_std_zrnic`."""
    pairs = np.asarray(pulses, float) - 1
    return np.sqrt(width_ms * wavelength_m / (8 * pairs * prt_s * np.sqrt(np.pi)))


def width_statistics(pulses, prt_s, wavelength_m, width_ms, snr_db):
    """Bias and std (m/s) of the width ``w = K sqrt(ln(S / |R_1|))``, large M.

    The perturbation analysis of this estimator (Zrnic 1979, "Spectrum width estimates for
    weather echoes", IEEE Trans. Aerosp. Electron. Syst. 15, 613-619; Doviak & Zrnic 1993
    sect. 6.5), written out here for a Gaussian spectrum in white noise with noise-corrected
    power and infinite sums (``A_0 = sum rho(k)^2 = 1 / (2 sqrt(pi) sigma_vn)``,
    ``sum rho(k) rho(k+1) = exp(-a/2) A_0``, ``rho(k) = exp(-a k^2)``, ``n = N/S``). With
    ``L = ln(S/|R_1|) = a``:
    ``M var(L) = A_0 [1 + (e^{2a} + 1)/2 - 2 e^{a/2}] + 2n + n^2 + e^{2a} (2n + n^2 +
    2 e^{-4a} n) / 2 - 4n``, ``M E[dL] = -n (1 - e^{-2a}) - n^2/2``, and
    ``std(w) = w sqrt(var L) / (2a)``, ``bias(w) = w (E[dL] / (2a) - var(L) / (8 a^2))``.
    At high SNR and small ``sigma_vn`` the variance tends to ``3 sigma_v lambda /
    (64 sqrt(pi) M T)``. Valid only while ``sqrt(var L) << a`` (see
    :func:`width_log_ratio_cv`). This is our own evaluation, not a published expression
    copied verbatim; it is checked against the exact delta method in the tests.
    """
    m = np.asarray(pulses, float)
    a = _gaussian_decay(width_ms, prt_s, wavelength_m)
    n = 10 ** (-np.asarray(snr_db, float) / 10)
    a0 = _independent_sample_sum(pulses, prt_s, wavelength_m, width_ms, large_m=True)
    signal = a0 * (1 + (np.exp(2 * a) + 1) / 2 - 2 * np.exp(a / 2))
    noise = 2 * n + n**2 + np.exp(2 * a) * (2 * n + n**2 + 2 * np.exp(-4 * a) * n) / 2 - 4 * n
    var_l = (signal + noise) / m
    mean_dl = (-n * (1 - np.exp(-2 * a)) - n**2 / 2) / m
    w = np.asarray(width_ms, float)
    return w * (mean_dl / (2 * a) - var_l / (8 * a**2)), w * np.sqrt(var_l) / (2 * a)


def polarimetric_statistics_mz(pulses, prt_s, wavelength_m, width_ms, snr_db, zdr_db, rho_hv):
    """Bias and std of Z_DR (dB), rho_hv and phi_DP (deg), large M, Gaussian spectrum.

    Melnikov & Zrnic (2004), *Simultaneous transmission mode for the polarimetric WSR-88D:
    statistical biases and standard deviations of polarimetric variables*, NSSL/CIMMS report
    (sects. 2-4); Melnikov & Zrnic (2007), J. Atmos. Oceanic Technol. 24, 1337-1350; Bringi &
    Chandrasekar (2001), *Polarimetric Doppler Weather Radar*, sect. 6.5. First-order
    perturbation with noise-corrected powers, ``A_0 = 1 / (2 sqrt(pi) sigma_vn)`` (large M),
    ``n_h = N/S_H``, ``n_v = N/S_V``:

    * ``M var(ln Z_DR) = 2 A_0 (1 - rho^2) + 2 n_h + n_h^2 + 2 n_v + n_v^2``, std in dB is
      4.343 times its root; bias ``4.343 (2 n_v + n_v^2 - 2 n_h - n_h^2) / (2M)`` dB;
    * ``M var(rho) = A_0 (1 - rho^2)^2 / 2 + (n_h + n_v)(1 - rho^2) / 2 + n_h n_v / 2 +
      rho^2 (n_h^2 + n_v^2) / 4``; bias ``rho (2 n_h + n_h^2 + 2 n_v + n_v^2) / (4M) +
      var(rho) / (2 rho)`` (noise-free: ``(1 - rho^2)^2 A_0 / (4 M rho)``);
    * ``M var(phi_DP) = [A_0 (1 - rho^2) + n_h + n_v + n_h n_v] / (2 rho^2)`` rad^2, unbiased.

    Without noise these are the textbook ``var(ln Z_DR) = 2 (1 - rho^2) / M_I``,
    ``var(rho) = (1 - rho^2)^2 / (2 M_I)``, ``var(phi) = (1 - rho^2) / (2 M_I rho^2)`` with
    ``M_I = M / A_0 = 2 sqrt(pi) sigma_vn M``.

    Returns
    -------
    dict
        ``name -> (bias, std)`` for ZDR, RHOHV and PHIDP.
    """
    m = np.asarray(pulses, float)
    _, s_v, n_h = _normalised_powers(snr_db, zdr_db)
    n_v = n_h / s_v
    rho = np.asarray(rho_hv, float)
    a0 = _independent_sample_sum(pulses, prt_s, wavelength_m, width_ms, large_m=True)
    var_zdr = (2 * a0 * (1 - rho**2) + 2 * n_h + n_h**2 + 2 * n_v + n_v**2) / m
    bias_zdr = DB * (2 * n_v + n_v**2 - 2 * n_h - n_h**2) / (2 * m)
    var_rho = (
        a0 * (1 - rho**2) ** 2 / 2
        + (n_h + n_v) * (1 - rho**2) / 2
        + n_h * n_v / 2
        + rho**2 * (n_h**2 + n_v**2) / 4
    ) / m
    bias_rho = rho * (2 * n_h + n_h**2 + 2 * n_v + n_v**2) / (4 * m) + var_rho / (2 * rho)
    var_phi = (a0 * (1 - rho**2) + n_h + n_v + n_h * n_v) / (2 * rho**2 * m)
    return {
        "ZDR": (bias_zdr, DB * np.sqrt(var_zdr)),
        "RHOHV": (bias_rho, np.sqrt(var_rho)),
        "PHIDP": (np.zeros(np.shape(var_phi)), np.rad2deg(np.sqrt(var_phi))),
    }


def closed_form_statistics(
    pulses, prt_s, wavelength_m, width_ms, velocity_ms, snr_db, zdr_db, rho_hv, phidp_deg
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Large-M literature closed forms of bias and std of the six moments, for cross-checking.

    DBZH: :func:`power_statistics_dz`; VRADH: :func:`velocity_std_zrnic` (bias 0); WRADH:
    :func:`width_statistics`; ZDR, RHOHV, PHIDP: :func:`polarimetric_statistics_mz`. The
    velocity and phi_DP do not enter (Gaussian spectrum, no aliasing). Arguments and return
    value as in :func:`estimator_statistics`.
    """
    del velocity_ms, phidp_deg  # the statistics do not depend on them
    out = {"DBZH": power_statistics_dz(pulses, prt_s, wavelength_m, width_ms, snr_db)}
    v_std = velocity_std_zrnic(pulses, prt_s, wavelength_m, width_ms, snr_db)
    out["VRADH"] = (np.zeros(np.shape(v_std)), v_std)
    out["WRADH"] = width_statistics(pulses, prt_s, wavelength_m, width_ms, snr_db)
    out.update(
        polarimetric_statistics_mz(pulses, prt_s, wavelength_m, width_ms, snr_db, zdr_db, rho_hv)
    )
    return {k: out[k] for k in MOMENTS}


# ---- Monte Carlo of the estimator itself ---------------------------------------------------------


def monte_carlo_statistics(
    pulses: int,
    prt_s: float,
    wavelength_m: float,
    width_ms: float,
    velocity_ms: float,
    snr_db: float,
    zdr_db: float,
    rho_hv: float,
    phidp_deg: float,
    gates: int = 20_000,
    seed: int = 0,
) -> dict[str, tuple[float, float]]:
    """Bias and std of the six moments from ``ppp.pulse_pair`` on ideal Gaussian I/Q.

    The reference where the delta method does not hold (the width of narrow spectra at low SNR
    or short dwells). I/Q of ``gates`` independent dwells are drawn by Cholesky colouring of
    the exact joint H-V covariance (signal plus noise, the model of the module docstring) and
    put through the estimator exactly as implemented, so its masking (NaN where a corrected
    power is not positive; excluded here) and its zero width where ``|R_1|`` exceeds the
    corrected power are included. Scalar arguments, as in :func:`estimator_statistics`; the
    standard error of a bias is about ``std / sqrt(gates)``.
    """
    from pasim_blocks.processing.pulse_pair import pulse_pair

    m = int(pulses)
    s_h, s_v, noise = _normalised_powers(snr_db, zdr_db)
    k = np.arange(m)[:, None] - np.arange(m)[None, :]
    base = np.exp(
        -_gaussian_decay(width_ms, prt_s, wavelength_m) * k**2
        - 4j * np.pi * velocity_ms * prt_s / wavelength_m * k
    )  # base[i, j] = rho(i - j) exp(-j omega (i - j)) = E[x_i x_j^*] / S
    sigma = np.zeros((2 * m, 2 * m), complex)
    sigma[:m, :m] = s_h * base + noise * np.eye(m)
    sigma[m:, m:] = s_v * base + noise * np.eye(m)
    sigma[m:, :m] = np.sqrt(s_h * s_v) * rho_hv * np.exp(1j * np.deg2rad(phidp_deg)) * base
    sigma[:m, m:] = sigma[m:, :m].conj().T
    chol = np.linalg.cholesky(sigma)  # positive definite thanks to the noise
    rng = np.random.default_rng(seed)
    w = (rng.standard_normal((gates, 2 * m)) + 1j * rng.standard_normal((gates, 2 * m))) / np.sqrt(
        2
    )
    h = w[:, :m] @ chol[:m, :m].T
    v = w[:, :m] @ chol[m:, :m].T + w[:, m:] @ chol[m:, m:].T
    est = pulse_pair(h, v, noise, noise, prt_s, wavelength_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        est["DBZH"] = 10 * np.log10(np.where(est["S_H"] > 0, est["S_H"], np.nan))
    nyquist = wavelength_m / (4 * prt_s)
    truth = {
        "DBZH": 10 * np.log10(s_h),
        "VRADH": velocity_ms,
        "WRADH": width_ms,
        "ZDR": zdr_db,
        "RHOHV": rho_hv,
        "PHIDP": phidp_deg,
    }
    out = {}
    for name in MOMENTS:
        err = est[name] - truth[name]
        if name == "VRADH":
            err = (err + nyquist) % (2 * nyquist) - nyquist
        elif name == "PHIDP":
            err = (err + 180.0) % 360.0 - 180.0
        out[name] = (float(np.nanmean(err)), float(np.nanstd(err, ddof=1)))
    return out


def compare_with_reference(
    score: dict[str, dict[str, Any]],
    reference: dict[str, tuple[float, float]],
    theory: dict[str, tuple[Any, Any]] | None = None,
    reference_dwells: int = 20_000,
    std_tolerance: float = 0.15,
) -> dict[str, dict[str, Any]]:
    """Judge a run's scores (``pasim score --json``) against a reference (bias, std) per moment.

    std: within ``std_tolerance`` (15 %) of the reference. bias: within 15 % of the reference's
    or 4 standard errors of the difference of the two sample means, whichever is larger (4,
    not 3: a validation grid makes about 200 comparisons, and at 3 one false alarm would be
    expected). The run's standard error takes half its scored gates as independent
    (neighbouring gates share truth cells through the range weighting).
    """
    rows = {}
    for name, s in score.items():
        if name not in reference:
            continue
        bias_r, std_r = (float(x) for x in reference[name])
        n_eff = max(1.0, s["count"] / 2)
        se = float(np.hypot(s["std"] / np.sqrt(n_eff), std_r / np.sqrt(reference_dwells)))
        tol_bias = max(0.15 * abs(bias_r), 4 * se)
        row = {
            "std": s["std"],
            "std_reference": std_r,
            "std_ratio": s["std"] / std_r,
            "bias": s["bias"],
            "bias_reference": bias_r,
            "bias_tolerance": tol_bias,
            "count": s["count"],
            "ok": bool(
                abs(s["std"] / std_r - 1) <= std_tolerance and abs(s["bias"] - bias_r) <= tol_bias
            ),
        }
        if theory is not None and name in theory:
            row["bias_theory"] = float(theory[name][0])
            row["std_theory"] = float(theory[name][1])
        rows[name] = row
    return rows
