"""An independent GMAP (Siggia and Passarelli 2004) for checking the simulator's filter.

Written apart from ``pasim_blocks.processing.gmap`` and ``pasim_blocks.processing.spectral``
(nothing is imported from either): one gate at a time, explicit DFT sums, the clutter model
as the quadratic form of the window with the clutter's covariance matrix, windows from
scipy.signal.windows. The algorithm, per gate (dwell x of M samples, noise power N, PRT T,
wavelength lambda, Nyquist velocity v_a = lambda / (4 T)):

1. First look with the Hamming window. Clutter power C = (three central bins - 3 N / M) /
   (the clutter model's share in those bins); C <= 0: no clutter, rectangular window, no
   filtering.
2. Window: of rectangular, Hamming, Blackman, Blackman-Harris the first whose clutter model,
   scaled to C, stands above N / M no more than one bin further from zero velocity than the
   model of any of the four does.
3. Periodogram with that window; C again on its three central bins; remove every bin out to
   the outermost where the model exceeds N / M (at least one bin each side of zero, at most
   M / 2 - 2).
4. Weather Gaussian from the remaining bins minus N / M: power R0, velocity from the phase
   of R1 = sum p_k exp(j pi v_k / v_a), width v_a / pi sqrt(2 ln(R0 / |R1|)).
5. Refill the removed bins with that Gaussian (aliases summed, normalised to R0 over the
   bins) plus N / M; R0 and R1 again over all bins; repeat until the power changes by less
   than 0.01 dB and the velocity by less than 0.05 % of 2 v_a.
6. If the three central bins hold no more than 3 times the refill's (model plus noise)
   there, the gate had no clutter after all: back to the unfiltered spectrum.
7. Moments of the refilled spectrum S: power sum S - N; R1 = sum S_k exp(j 2 pi k / M)
   divided by the window's lag-1 overlap; velocity -lambda / (4 pi T) arg R1; width
   lambda / (2 sqrt(2) pi T) sqrt(ln(power / |R1|)).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import windows

CLUTTER_FACTOR = 3.0  # clutter only where the central bins exceed 3 x the refill
NAMES = ("rectangular", "hamming", "blackman", "blackman_harris")
_SCIPY = {
    "rectangular": windows.boxcar,
    "hamming": windows.hamming,
    "blackman": windows.blackman,
    "blackman_harris": windows.blackmanharris,
}


class Radar:
    """Per-dwell constants: windows, DFT matrix, bin velocities and clutter models."""

    def __init__(self, pulses: int, prt_s: float, wavelength_m: float, clutter_width_ms: float):
        m = pulses
        self.m, self.prt, self.lam = m, prt_s, wavelength_m
        self.va = wavelength_m / (4 * prt_s)
        n = np.arange(m)
        self.dft = np.exp(-2j * np.pi * np.outer(n, n) / m)  # bin k, sample n
        k_signed = np.where(n < m / 2, n, n - m)
        # Bin k holds Doppler frequency k / (M T); velocity = -lambda f / 2 (positive away).
        self.v = -wavelength_m * k_signed / (m * prt_s) / 2
        self.dist = np.abs(k_signed)
        self.w = {name: _SCIPY[name](m, sym=True) for name in NAMES}
        tau = (n[:, None] - n[None, :]) * prt_s
        cov = np.exp(-8 * (np.pi * clutter_width_ms * tau / wavelength_m) ** 2)
        self.model = {}
        for name, w in self.w.items():
            a = self.dft * w[None, :]  # row k: the windowed DFT vector
            expected = np.einsum("kn,nl,kl->k", a, cov, a.conj()).real
            self.model[name] = expected / (m * np.sum(w**2))

    def spectrum(self, x: np.ndarray, name: str) -> np.ndarray:
        w = self.w[name]
        return np.abs(np.sum(self.dft * (w * x)[None, :], axis=1)) ** 2 / (self.m * np.sum(w**2))

    def clutter_power(self, s: np.ndarray, nb: float, name: str) -> float:
        c = [0, 1, self.m - 1]
        return max(float(s[c].sum() - 3 * nb), 0.0) / float(self.model[name][c].sum())

    def reach(self, power: float, nb: float, name: str) -> int:
        if power <= 0:
            return 0
        over = self.dist[power * self.model[name] > nb]
        r = int(over.max()) if over.size else 0
        return min(max(r, 1), self.m // 2 - 2)

    def choose(self, x: np.ndarray, noise: float) -> str:
        nb = noise / self.m
        c = self.clutter_power(self.spectrum(x, "hamming"), nb, "hamming")
        if c <= 0:
            return "rectangular"
        reach = [self.reach(c, nb, name) for name in NAMES]
        return next(n for n, r in zip(NAMES, reach, strict=True) if r <= min(reach) + 1)

    def _fit(self, p: np.ndarray) -> tuple[float, float, float]:
        r0 = float(p.sum())
        r1 = complex(np.sum(p * np.exp(1j * np.pi * self.v / self.va)))
        vel = self.va / np.pi * np.angle(r1)
        ratio = np.log(r0 / abs(r1)) if r0 > 0 and abs(r1) > 0 else 0.0
        return r0, vel, self.va / np.pi * np.sqrt(2 * max(ratio, 0.0))

    def _gauss(self, power: float, vel: float, width: float) -> np.ndarray:
        width = max(width, 1e-3)
        g = np.zeros(self.m)
        for j in range(-3, 4):
            g += np.exp(-((self.v - vel + 2 * j * self.va) ** 2) / (2 * width**2))
        return power * g / g.sum() if g.sum() > 0 else np.zeros(self.m)

    def filter(self, s: np.ndarray, noise: float, name: str, iterations: int = 200):
        """GMAP on one spectrum: (refilled spectrum, number of bins removed)."""
        nb = noise / self.m
        r = self.reach(self.clutter_power(s, nb, name), nb, name)
        if r == 0:
            return s, 0
        gone = self.dist <= r
        original, s = s, s.copy()
        power, vel, width = self._fit(np.where(gone, 0.0, s - nb))
        for _ in range(iterations):
            s[gone] = self._gauss(max(power, 0.0), vel, width)[gone] + nb
            p2, v2, w2 = self._fit(s - nb)
            dv = abs((v2 - vel + self.va) % (2 * self.va) - self.va)
            if p2 <= 0 and power <= 0:
                break
            same = p2 > 0 and power > 0 and abs(10 * np.log10(p2 / power)) < 0.01
            power, vel, width = p2, v2, w2
            if same and dv < 0.0005 * 2 * self.va:
                break
        c = [0, 1, self.m - 1]
        if original[c].sum() <= CLUTTER_FACTOR * s[c].sum():
            return original, 0  # the central bins are the weather's own: no clutter
        return s, int(gone.sum())

    def moments(self, s: np.ndarray, noise: float, name: str) -> tuple[float, float, float]:
        w = self.w[name]
        power = float(s.sum() - noise)
        overlap = np.sum(w[:-1] * w[1:]) / np.sum(w**2)
        r1 = complex(np.sum(s * np.exp(2j * np.pi * np.arange(self.m) / self.m))) / overlap
        if power <= 0 or abs(r1) == 0:
            return power, np.nan, np.nan
        vel = -self.lam / (4 * np.pi * self.prt) * np.angle(r1)
        width = (
            self.lam
            / (2 * np.sqrt(2) * np.pi * self.prt)
            * np.sqrt(max(np.log(power / abs(r1)), 0.0))
        )
        return power, vel, width


def gmap_moments(
    iq: np.ndarray, noise_w: np.ndarray, prt_s: float, wavelength_m: float, clutter_width_ms: float
) -> dict[str, np.ndarray]:
    """Power (W), velocity and width (m/s) after GMAP, and the window chosen, per gate.

    ``iq``: gate x pulse (H channel); ``noise_w``: noise power per gate.
    """
    iq = np.asarray(iq, np.complex128)
    radar = Radar(iq.shape[-1], prt_s, wavelength_m, clutter_width_ms)
    out = {k: np.full(iq.shape[0], np.nan) for k in ("power", "velocity", "width")}
    chosen = []
    for g, (x, n) in enumerate(zip(iq, np.asarray(noise_w, np.float64), strict=True)):
        name = radar.choose(x, n)
        s, _ = radar.filter(radar.spectrum(x, name), n, name)
        out["power"][g], out["velocity"][g], out["width"][g] = radar.moments(s, n, name)
        chosen.append(name)
    out["window"] = np.array(chosen)
    return out
