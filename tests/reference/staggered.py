"""Theoretical standard deviation of the staggered-PRT velocity estimate.

The dealiased velocity of Torres, Dubel and Zrnic (2004) is the T1 estimate
v1 = -lambda / (4 pi T1) arg R(T1), unfolded; where the unfolding is right its error is v1's.
To first order (the perturbation analysis of Zrnic 1977 and Zrnic and Mahapatra 1985, here
without their large-M approximations), with Z = R(T1) = (1/K) sum_k x*_a(k) x_b(k) over the
K pairs (a, b) = (2k, 2k + 1) and theta = arg E[Z],

    var(v1) = (lambda / (4 pi T1))^2 var(Im(Z e^(-j theta))) / |E Z|^2,
    var(Im W) = (E|W - EW|^2 - Re E[(W - EW)^2]) / 2,

and the two second moments follow from Isserlis' theorem for circular Gaussian samples with
the exact covariance C[i, j] = E[x_i x_j*] = S rho(t_i - t_j) e^(-j 4 pi v (t_i - t_j) / lambda)
+ N delta_ij at the staggered pulse times t (Gaussian spectrum, rho(tau) =
exp(-8 (pi w tau / lambda)^2)):

    cov(z_k, z_l*) = C[c, a] C[b, d],   E[(z_k - .)(z_l - .)] = C[d, a] C[b, c]

for z_k = x*_a x_b, z_l = x*_c x_d. It shares nothing with the processor's code.
"""

from __future__ import annotations

import numpy as np


def staggered_times(t1_s: float, ratio: float, pulses: int) -> np.ndarray:
    steps = np.where(np.arange(pulses - 1) % 2 == 0, t1_s, t1_s / ratio)
    return np.concatenate([[0.0], np.cumsum(steps)])


def v1_std(
    t1_s: float,
    ratio: float,
    pulses: int,
    wavelength_m: float,
    velocity_ms: float,
    width_ms: float,
    snr_db: float,
) -> float:
    t = staggered_times(t1_s, ratio, pulses)
    tau = t[:, None] - t[None, :]
    c = np.exp(-8 * (np.pi * width_ms * tau / wavelength_m) ** 2) * np.exp(
        -4j * np.pi * velocity_ms * tau / wavelength_m
    )
    c = c + 10 ** (-snr_db / 10) * np.eye(t.size)
    a = np.arange(0, pulses - 1, 2)
    b = a + 1
    mean = np.mean(c[b, a])
    var_c = np.mean(c[np.ix_(a, a)].T * c[np.ix_(b, b)])  # C[c, a] C[b, d], k rows, l cols
    pvar = np.mean(c[np.ix_(b, a)].T * c[np.ix_(b, a)])  # C[d, a] C[b, c]
    pvar *= np.exp(-2j * np.angle(mean))
    var_im = (var_c.real - pvar.real) / 2
    return float(wavelength_m / (4 * np.pi * t1_s) * np.sqrt(var_im) / abs(mean))
