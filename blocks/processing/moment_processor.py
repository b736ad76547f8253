"""The moment processors' base: what every one of them reads, declares and hands back.

A processor (pulse-pair, spectral, staggered PRT, SZ-2, or a plugin's) turns one chunk of
received I/Q into calibrated moments. Its inputs, censoring thresholds and output port are
the same for all of them, so :class:`MomentProcessor` declares them once; so are the first
step of ``process`` (:meth:`MomentProcessor.dwell`: the inputs unpacked, the PRT, wavelength
and transmission read, the transmission checked) and the last (:meth:`MomentProcessor.
moments_output`: the transmit differential phase removed from phi_DP, then the CfRadial Dataset of
:func:`~pasim_blocks.processing.output.moments_dataset`). A processor writes the estimator
between the two.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Input, Output, Param
from pasim_graph.fm301 import MOMENT_FIELDS, POLARIMETRIC_FIELDS

from ..signals import BEAMS, CALIBRATION, IQ, MOMENTS, NOISE_POWER, check_pulses
from .output import Censoring, moments_dataset, thresholds


class Dwell(NamedTuple):
    """One chunk's inputs as a processor reads them."""

    iq: np.ndarray  # beam x gate x pulse x channel (H, V)
    noise: np.ndarray  # beam x gate x channel, W
    calibration: xr.Dataset
    beams: xr.Dataset
    prt_s: float  # the first beam's PRT (T1 of a staggered scan)
    wavelength_m: float
    transmission: str  # "shv" (simultaneous) or "ahv" (alternate)
    transmit_phidp_deg: float  # the system's differential phase on transmit
    polarimetric: bool  # the run asked for ZDR, RHOHV or PHIDP
    dual: bool  # ... and the calibration says the radar is dual-polarised


class MomentProcessor(Censoring, Block):
    """Base of the moment processors: the four inputs, the censoring thresholds and the
    ``moments`` output declared once, and the shared first and last steps of ``process``.

    A subclass sets :attr:`transmissions` to the transmission modes its estimators handle,
    may re-declare ``moments`` to list the fields it writes, and implements ``process`` as
    ``d = self.dwell(inputs, chunk)``, its estimates, then ``self.moments_output(est, ...)``.
    """

    #: Transmission modes (the calibration's ``transmission``) the estimators handle.
    transmissions: ClassVar[tuple[str, ...]] = ("shv",)

    iq = Input(IQ, doc="received I/Q")
    noise_power = Input(NOISE_POWER, doc="noise power per channel")
    calibration = Input(CALIBRATION, doc="radar constant and gate ranges")
    beams = Input(BEAMS, doc="beam geometry (PRT, PRT ratio, transmit phases)")
    moments = Output(MOMENTS, store="moments", doc="estimated moments", fields=MOMENT_FIELDS)
    motion_compensation = Param(
        False,
        type="bool",
        doc="remove the platform's velocity along each beam (a moving scan's "
        "platform_radial_velocity) from the echo before estimating, as airborne radars do",
    )

    def setup(self) -> None:
        self._threshold_db = thresholds(self.p)

    def dwell(self, inputs: dict[str, Any], chunk: Chunk) -> Dwell:
        """The chunk's inputs unpacked, with what every estimator needs read from them;
        a transmission the processor does not handle is refused, and so is an I/Q cube whose
        pulse axis contradicts the run's level (:func:`~pasim_blocks.signals.check_pulses`:
        a processor decides on ``chunk.expected``, not on the axis)."""
        cal, beams = inputs["calibration"], inputs["beams"]
        mode = str(cal.attrs.get("transmission", "shv"))
        if mode not in self.transmissions:
            raise ValueError(
                f"{self.type_name or type(self).__name__} handles transmission "
                f"{' or '.join(self.transmissions)}; the weather channel's transmission is "
                f"{mode!r}"
            )
        polarimetric = chunk.wants(*POLARIMETRIC_FIELDS)
        iq = inputs["iq"]
        check_pulses(iq, chunk, self.name)
        if self.p["motion_compensation"] and "platform_radial_velocity" in beams:
            iq = self._compensated(iq, beams, float(cal.attrs["wavelength_m"]))
        return Dwell(
            iq=iq,
            noise=inputs["noise_power"],
            calibration=cal,
            beams=beams,
            prt_s=float(beams["prt"].values[0]),
            wavelength_m=float(cal.attrs["wavelength_m"]),
            transmission=mode,
            transmit_phidp_deg=float(cal.attrs.get("transmit_differential_phase_deg", 0.0)),
            polarimetric=polarimetric,
            dual=bool(cal.attrs.get("dual_polarization", 1)) and polarimetric,
        )

    def _compensated(self, iq: np.ndarray, beams: xr.Dataset, wavelength_m: float) -> np.ndarray:
        """The I/Q (beam x gate x pulse x channel) with each beam's platform Doppler removed:
        pulse m times exp(-j 4 pi v_p m T / lambda)."""
        if "prt_ratio" in beams:
            raise ValueError(
                f"{self.type_name or type(self).__name__}: motion_compensation needs a uniform "
                "PRT (the scan's stagger is not uniform)"
            )
        vp = beams["platform_radial_velocity"].values
        t = np.arange(iq.shape[2]) * float(beams["prt"].values[0])
        phase = np.exp(-4j * np.pi / wavelength_m * vp[:, None] * t[None, :])
        return iq * phase.astype(iq.dtype)[:, None, :, None]

    def compensated_correlations(self, corr: np.ndarray, dwell: Dwell) -> np.ndarray:
        """Expected echo correlations (beam x gate x product) with the platform Doppler
        removed at each product's lag, when motion compensation is on (else as given)."""
        beams = dwell.beams
        if not (self.p["motion_compensation"] and "platform_radial_velocity" in beams):
            return corr
        from ..weather.motion import LAGS

        vp = beams["platform_radial_velocity"].values
        k = 4.0 * np.pi / dwell.wavelength_m
        return corr * np.exp(-1j * k * vp[:, None] * LAGS[None, :] * dwell.prt_s)[:, None, :]

    def moments_output(
        self,
        est: dict[str, np.ndarray],
        noise_h: np.ndarray,
        dwell: Dwell,
        chunk: Chunk,
        nyquist_ms: float,
        **options: Any,
    ) -> dict[str, Any]:
        """The block's output from noise-corrected estimates (see
        :func:`~pasim_blocks.processing.output.moments_dataset`, which ``options`` are passed
        on to): phi_DP of simultaneous transmission calibrated for the known transmit
        differential phase, phi_DP's period (180 deg for alternate transmission) recorded."""
        beta = dwell.transmit_phidp_deg
        if "PHIDP" in est and dwell.transmission == "shv" and beta:
            # The system's differential phase on transmit is known: calibrated out.
            est["PHIDP"] = np.mod(est["PHIDP"] - beta, 360.0)
        attrs = {
            "transmission": dwell.transmission,
            "phidp_period_deg": 180.0 if dwell.transmission == "ahv" else 360.0,
        }
        ds = moments_dataset(
            est, noise_h, dwell.calibration, chunk, self._threshold_db, nyquist_ms, attrs, **options
        )
        return {"moments": ds}
