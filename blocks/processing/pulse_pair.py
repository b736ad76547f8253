"""Pulse-pair processing: the six moments from the I/Q of each gate."""

from __future__ import annotations

from typing import Any

import numpy as np

from pasim_graph import Chunk, Input

from ..signals import CORRELATION_PRODUCTS, ECHO_CORRELATIONS
from ..timing import cohere_first_trip
from .moment_processor import MomentProcessor


def correlations(iq_h: np.ndarray, iq_v: np.ndarray | None, doppler: bool = True) -> dict:
    """Sample correlations along the last (pulse) axis: lag-0 H and V, lag-1 H, lag-0 E[h* v].

    ``iq_v`` None (single polarisation, or no polarimetric field asked for) and ``doppler``
    False leave out what they need.
    """
    out = {"R0_H": np.mean(np.abs(iq_h) ** 2, axis=-1)}
    if doppler:
        out["R1_H"] = np.mean(np.conj(iq_h[..., :-1]) * iq_h[..., 1:], axis=-1)
    if iq_v is not None:
        out["R0_V"] = np.mean(np.abs(iq_v) ** 2, axis=-1)
        out["R0_HV"] = np.mean(np.conj(iq_h) * iq_v, axis=-1)
    return out


def alternate_correlations(
    iq_h: np.ndarray, iq_v: np.ndarray | None, doppler: bool = True, polarimetric: bool = True
) -> dict:
    """Sample correlations of an alternate-transmission (AHV) dwell along the pulse axis.

    Pulses alternate H (even) and V (odd) transmission; both ports receive every pulse. h is
    the H port on H pulses and v the V port on V pulses. Returns lag-0 powers of h and v,
    their lag-2 autocorrelations (``R2_H``, ``R2_V``; one transmit period, 2T, apart) and the
    lag-1 cross-correlations of consecutive pulses, ``R1_HV`` = <h_2k* v_2k+1> and ``R1_VH`` =
    <v_2k+1* h_2k+2> (the R_a and R_b of Zrnic 1991). ``iq_v`` None, ``doppler`` or
    ``polarimetric`` False leave out what needs them.
    """
    h = iq_h[..., 0::2]
    out = {"R0_H": np.mean(np.abs(h) ** 2, axis=-1)}
    if doppler:
        out["R2_H"] = np.mean(np.conj(h[..., :-1]) * h[..., 1:], axis=-1)
    if iq_v is not None:
        v = iq_v[..., 1::2]
        out["R0_V"] = np.mean(np.abs(v) ** 2, axis=-1)
        out["R2_V"] = np.mean(np.conj(v[..., :-1]) * v[..., 1:], axis=-1)
        if polarimetric:
            n = v.shape[-1]
            out["R1_HV"] = np.mean(np.conj(h[..., :n]) * v, axis=-1)
            out["R1_VH"] = np.mean(np.conj(v[..., : h.shape[-1] - 1]) * h[..., 1:], axis=-1)
    return out


def _velocity_width(
    power: np.ndarray, ok: np.ndarray, r: np.ndarray, lag_s: float, wavelength_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and width (Gaussian spectrum) from the noise-corrected power and the
    autocorrelation ``r`` at lag ``lag_s``; NaN where not ``ok`` or where ``r`` is zero."""
    ok = ok & (np.abs(r) > 0)
    velocity = -wavelength_m / (4 * np.pi * lag_s) * np.angle(r)
    ratio = np.log(np.where(ok, power, np.nan) / np.abs(r))
    # |R| above the corrected power (noise or short dwell): width below resolution.
    width = wavelength_m / (2 * np.sqrt(2) * np.pi * lag_s) * np.sqrt(np.maximum(ratio, 0))
    nan = np.float64(np.nan)
    return np.where(ok, velocity, nan), np.where(ok, width, nan)


def alternate_moments(
    corr: dict,
    noise_h: float | np.ndarray,
    noise_v: float | np.ndarray,
    prt_s: float,
    wavelength_m: float,
) -> dict[str, np.ndarray]:
    """Noise-corrected estimates of an alternate-transmission (AHV) dwell (Zrnic 1991).

    With T the pulse spacing, S_h and S_v the noise-corrected powers of h and v, R(2T) =
    R2_H + R2_V (the co-polar lag 2, one transmit period), R_a = R1_HV and R_b = R1_VH:

    - velocity -lambda / (8 pi T) arg R(2T): Nyquist velocity lambda / (8T), half of SHV's;
    - width lambda / (4 sqrt(2) pi T) sqrt(ln((S_h + S_v) / |R(2T)|)) (Gaussian spectrum);
    - ZDR S_h / S_v;
    - rho_hv (|R_a| + |R_b|) / (2 sqrt(S_h S_v) rho(T)), rho(T) = rho(2T)^(1/4) with rho(2T) =
      |R(2T)| / (S_h + S_v) (the Gaussian spectrum's lag-1 coherency from its lag 2);
    - phi_DP arg(R_a R_b*) / 2: the Doppler phase cancels; phi_DP comes modulo 180 deg, in
      [0, 180) (phi_DP + 180 deg with a velocity shift of lambda / (4T), one SHV Nyquist
      velocity and the width of the AHV interval, gives the same alternate pulses).

    Returns what the correlations allow of, as :func:`moments_from_correlations` does.
    """
    p_h = np.real(corr["R0_H"]) - noise_h
    ok_h = p_h > 0
    nan = np.float64(np.nan)
    out: dict[str, np.ndarray] = {"S_H": p_h}
    with np.errstate(divide="ignore", invalid="ignore"):
        p_v = np.real(corr["R0_V"]) - noise_v if "R0_V" in corr else None
        if "R2_H" in corr:
            r2 = corr["R2_H"] + (corr["R2_V"] if "R2_V" in corr else 0)
            power = p_h + (p_v if p_v is not None else 0)
            out["VRADH"], out["WRADH"] = _velocity_width(
                power, ok_h & (power > 0), r2, 2 * prt_s, wavelength_m
            )
        if p_v is not None:
            ok = ok_h & (p_v > 0)
            out["S_V"] = p_v
            out["ZDR"] = 10 * np.log10(np.where(ok, p_h / p_v, np.nan))
        if p_v is not None and "R1_HV" in corr:
            r_a, r_b = corr["R1_HV"], corr["R1_VH"]
            r2 = corr["R2_H"] + corr["R2_V"]
            coherency = (np.abs(r2) / np.where(ok, p_h + p_v, np.nan)) ** 0.25
            out["RHOHV"] = (np.abs(r_a) + np.abs(r_b)) / (
                2 * np.sqrt(np.where(ok, p_h * p_v, np.nan)) * coherency
            )
            out["PHIDP"] = np.where(
                ok, np.mod(np.rad2deg(np.angle(r_a * np.conj(r_b))) / 2, 180.0), nan
            )
    return out


def moments_from_correlations(
    corr: dict,
    noise_h: float | np.ndarray,
    noise_v: float | np.ndarray,
    prt_s: float,
    wavelength_m: float,
) -> dict[str, np.ndarray]:
    """Noise-corrected pulse-pair estimates from lag-0, lag-1 and H-V correlations.

    Returns what the correlations allow of: signal powers ``S_H``, ``S_V`` (W; may be
    negative, meaning noise dominates), velocity (m/s, positive away), spectrum width (m/s),
    ZDR (dB), rho_hv and phi_DP (deg, in [0, 360)). Estimates that are undefined are NaN: every
    one where S_H <= 0, the polarimetric ones where S_V <= 0.
    """
    p_h = np.real(corr["R0_H"]) - noise_h
    ok_h = p_h > 0
    nan = np.float64(np.nan)
    out: dict[str, np.ndarray] = {"S_H": p_h}
    with np.errstate(divide="ignore", invalid="ignore"):
        if "R1_H" in corr:
            out["VRADH"], out["WRADH"] = _velocity_width(
                p_h, ok_h, corr["R1_H"], prt_s, wavelength_m
            )
        if "R0_V" in corr:
            p_v = np.real(corr["R0_V"]) - noise_v
            r_hv = corr["R0_HV"]
            ok = ok_h & (p_v > 0)
            out["S_V"] = p_v
            out["ZDR"] = 10 * np.log10(np.where(ok, p_h / p_v, np.nan))
            out["RHOHV"] = np.abs(r_hv) / np.sqrt(np.where(ok, p_h * p_v, np.nan))
            out["PHIDP"] = np.where(ok, np.mod(np.rad2deg(np.angle(r_hv)), 360.0), nan)
    return out


def pulse_pair(
    iq_h: np.ndarray,
    iq_v: np.ndarray,
    noise_h: float | np.ndarray,
    noise_v: float | np.ndarray,
    prt_s: float,
    wavelength_m: float,
) -> dict[str, np.ndarray]:
    """Noise-corrected pulse-pair estimates of all six moments along the last (pulse) axis.

    See :func:`moments_from_correlations` for what is returned.
    """
    return moments_from_correlations(
        correlations(iq_h, iq_v), noise_h, noise_v, prt_s, wavelength_m
    )


class PulsePairProcessor(MomentProcessor):
    """Pulse-pair moments, noise-corrected, calibrated to dBZ with the radar constant.

    Power is lag-0 minus the known noise power; velocity is from the phase of the lag-1
    autocorrelation (positive away from the radar, as NEXRAD); width from the ratio of the
    noise-corrected lag-0 power to |lag-1| (Gaussian spectrum); ZDR from the two corrected
    powers; rho_hv = |lag-0 H-V cross-correlation| / sqrt(product of corrected powers), kept
    above 1 when the estimate is (clip only for display); phi_DP is its phase. Gates where the
    corrected power is not positive are masked. An I/Q cube without pulses (the weather
    channel's ``expected`` level) is estimated from the expected echo correlations instead,
    without noise. Single-polarisation runs (calibration ``dual_polarization`` 0) and runs
    that ask for some fields only skip what is not needed.

    The transmission mode comes from the calibration's attributes. In SHV the transmit
    differential phase is removed from phi_DP. In AHV (H on even pulses, V on odd) the
    estimators are those of Zrnic (1991) (:func:`alternate_moments`): powers and ZDR from
    each state's co-polar pulses, velocity and width from the co-polar lag 2 (Nyquist
    velocity lambda / (8T)), rho_hv and phi_DP (modulo 180 deg) from the lag-1 H-V
    cross-correlations with the lag-2 coherency correction.

    A phase-coded scan (scan.ppi's ``phase_code``) is cohered to the first trip first: each
    pulse is multiplied by the conjugate of its transmit phase, so a first-trip echo gives
    the moments it gives uncoded, and echoes of other trips stay spread by the code.
    """

    transmissions = ("shv", "ahv")

    echo_correlations = Input(
        ECHO_CORRELATIONS, required=False, doc="expected echo correlations (expected level)"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        d = self.dwell(inputs, chunk)
        iq, noise, prt, lam = d.iq, d.noise, d.prt_s, d.wavelength_m
        mode, polarimetric, dual = d.transmission, d.polarimetric, d.dual
        cal = d.calibration
        doppler = chunk.wants("VRADH", "WRADH")
        if "prt_ratio" in inputs["beams"]:
            raise ValueError(
                "the scan's PRT is staggered (scan.ppi's stagger): the pulse-pair processor "
                "assumes a uniform PRT; use processor.staggered"
            )
        iq = cohere_first_trip(iq, inputs["beams"])
        if mode == "ahv":
            # The weather channel draws V for AHV's velocity too (its lag 2 of H and V).
            use_v = bool(cal.attrs.get("dual_polarization", 1)) and (polarimetric or doppler)
            if chunk.expected:
                expected = self.compensated_correlations(self._expected(inputs), d)
                corr = {k: expected[..., i] for i, k in enumerate(CORRELATION_PRODUCTS)}
                keep = (
                    {"R0_H"}
                    | ({"R2_H"} if doppler or dual else set())
                    | ({"R0_V", "R2_V"} if use_v else set())
                    | ({"R1_HV", "R1_VH"} if dual else set())
                )
                est = alternate_moments(
                    {k: v for k, v in corr.items() if k in keep}, 0.0, 0.0, prt, lam
                )
            else:
                if iq.shape[2] < 4:
                    raise ValueError(
                        f"alternate transmission (the weather channel's transmission 'ahv') "
                        f"needs at least 4 pulses per dwell (2 of each polarisation for the "
                        f"lag 2), got {iq.shape[2]}: raise the scan's 'pulses'"
                    )
                corr = alternate_correlations(
                    iq[..., 0], iq[..., 1] if use_v else None, doppler or dual, dual
                )
                est = alternate_moments(corr, noise[..., 0], noise[..., 1], prt, lam)
        elif chunk.expected:
            # The weather channel's expected level: its expected correlations are what an
            # endless, noise-free dwell would measure.
            expected = self.compensated_correlations(self._expected(inputs), d)
            corr = {k: expected[..., i] for i, k in enumerate(CORRELATION_PRODUCTS)}
            keep = (
                {"R0_H"} | ({"R1_H"} if doppler else set()) | ({"R0_V", "R0_HV"} if dual else set())
            )
            est = moments_from_correlations(
                {k: v for k, v in corr.items() if k in keep}, 0.0, 0.0, prt, lam
            )
        else:
            corr = correlations(iq[..., 0], iq[..., 1] if dual else None, doppler)
            est = moments_from_correlations(corr, noise[..., 0], noise[..., 1], prt, lam)
        # AHV's velocity comes from a lag of two pulses: half the Nyquist velocity.
        nyquist = lam / (4 * prt) / (2 if mode == "ahv" else 1)
        return self.moments_output(est, noise[..., 0], d, chunk, nyquist)

    def _expected(self, inputs: dict[str, Any]) -> Any:
        """The expected echo correlations the expected level estimates from (it draws no
        pulses); refused naming the block when the input is not connected."""
        if inputs.get("echo_correlations") is None:
            raise ValueError(
                f"block '{self.name}': the weather channel's method 'expected' draws no pulses "
                "(the I/Q cube has none) but the input 'echo_correlations' is not connected; "
                "connect it to the weather channel's 'echo_correlations'"
            )
        return inputs["echo_correlations"]
