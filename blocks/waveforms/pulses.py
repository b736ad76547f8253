"""Transmit waveforms: the complex envelope of one pulse, sampled.

Every waveform comes out with peak amplitude 1 (1 = the transmitter's peak power) at a sample
rate that is either given (``sample_rate_hz``) or ``oversampling`` times the bandwidth.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Block, Chunk, Output, Param, RunNote

from ..signals import PULSE


def pulse_dataset(envelope: np.ndarray, sample_rate_hz: float, **attrs: Any) -> xr.Dataset:
    """Wrap a complex envelope (peak amplitude 1 = peak power) as a pulse signal."""
    n = envelope.size
    return xr.Dataset(
        {"envelope": ("sample", envelope.astype(np.complex128), {"units": "1"})},
        coords={"time": ("sample", np.arange(n) / sample_rate_hz, {"units": "s"})},
        attrs={"sample_rate_hz": float(sample_rate_hz), **attrs},
    )


class RectangularPulse(Block):
    """A rectangular pulse of constant amplitude and phase (no pulse compression)."""

    pulse = Output(PULSE, doc="transmit envelope, peak amplitude 1")

    width_s = Param(1.6e-6, units="s", min=1e-8, max=1e-3, doc="pulse width")
    sample_rate_hz = Param(
        20e6,
        units="Hz",
        min=1e5,
        max=1e10,
        doc="envelope sample rate (sets the range resolution of weighting)",
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        n = max(1, round(self.p["width_s"] * self.p["sample_rate_hz"]))
        return {
            "pulse": pulse_dataset(
                np.ones(n, complex),
                self.p["sample_rate_hz"],
                waveform="rectangular",
                width_s=self.p["width_s"],
            )
        }


class _SweptPulse(Block):
    """A frequency-modulated pulse of given bandwidth and width (shared declarations)."""

    pulse = Output(PULSE, doc="transmit envelope, peak amplitude 1")

    bandwidth_hz = Param(3.6e6, units="Hz", min=1e3, max=1e10, doc="swept bandwidth")
    width_s = Param(50e-6, units="s", min=1e-8, max=1e-2, doc="pulse width")
    sample_rate_hz = Param(
        None,
        units="Hz",
        min=1e3,
        max=1e11,
        optional=True,
        doc="envelope sample rate (default: oversampling x bandwidth)",
    )
    oversampling = Param(
        2.0, min=2.0, max=64.0, doc="sample rate over bandwidth, when sample_rate_hz is unset"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        def value(key: str) -> Any:
            return params.get(key, cls.params[key].default)

        rate, band, width = value("sample_rate_hz"), value("bandwidth_hz"), value("width_s")
        if rate is not None and rate < band:
            return [
                (
                    "parameter 'sample_rate_hz'",
                    f"{rate:g} Hz is below the bandwidth {band:g} Hz: a complex envelope needs "
                    "at least its bandwidth (2x or more to see sidelobes between samples)",
                )
            ]
        rate = rate if rate is not None else value("oversampling") * band
        if width * rate < 2:
            return [
                ("parameter 'width_s'", f"{width:g} s holds fewer than 2 samples at {rate:g} Hz")
            ]
        return []

    def rate(self) -> float:
        """The envelope's sample rate (Hz)."""
        given = self.p["sample_rate_hz"]
        return float(
            given if given is not None else self.p["oversampling"] * self.p["bandwidth_hz"]
        )

    def samples(self) -> int:
        return max(2, round(self.p["width_s"] * self.rate()))

    def dataset(self, envelope: np.ndarray, name: str) -> xr.Dataset:
        return pulse_dataset(
            envelope / np.max(np.abs(envelope)),
            self.rate(),
            waveform=name,
            width_s=envelope.size / self.rate(),
            bandwidth_hz=float(self.p["bandwidth_hz"]),
        )


class LinearFM(_SweptPulse):
    """Linear FM (chirp) from -B/2 to +B/2, with an optional transmit amplitude window.

    Phase pi (B / T) t^2 about the pulse centre. The window (scipy.signal.windows) lowers the
    range sidelobes at the cost of energy: a Taylor window of -60 dB keeps about 0.34 of a
    constant envelope's energy (the paper's section 2.3 quotes 0.35). Through the matched
    filter the output is near the Fourier transform of the squared window (stationary phase).
    """

    window = Param(
        "none", type="str", choices=("none", "taylor", "tukey"), doc="transmit amplitude window"
    )
    taylor_sidelobe_db = Param(
        -60.0, units="dB", min=-150.0, max=-13.0, doc="Taylor window sidelobe level"
    )
    taylor_nbar = Param(
        10, type="int", min=1, max=100, doc="Taylor window: number of near sidelobes held level"
    )
    tukey_fraction = Param(
        0.1, min=0.0, max=1.0, doc="Tukey window: fraction of the pulse in the cosine edges"
    )

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        import scipy.signal.windows as windows

        n, fs = self.samples(), self.rate()
        t = (np.arange(n) - (n - 1) / 2) / fs
        slope = self.p["bandwidth_hz"] / (n / fs)
        env = np.exp(1j * np.pi * slope * t**2)
        name = "lfm"
        if self.p["window"] == "taylor":
            env = env * windows.taylor(
                n, nbar=self.p["taylor_nbar"], sll=-self.p["taylor_sidelobe_db"], norm=True
            )
            name = f"lfm, Taylor {self.p['taylor_sidelobe_db']:g} dB"
        elif self.p["window"] == "tukey":
            env = env * windows.tukey(n, self.p["tukey_fraction"])
            name = f"lfm, Tukey {self.p['tukey_fraction']:g}"
        return {"pulse": self.dataset(env, name)}


class NonlinearFM(_SweptPulse):
    """Nonlinear FM designed by the stationary-phase principle (blocks/nlfm.py).

    ``design = gaussian``: the frequency law that gives a Gaussian spectral density of
    standard deviation ``density_std_fraction`` x bandwidth, truncated to the band (the
    paper's section 2.3 waveform), with a constant envelope unless ``taper_fraction`` is set.
    ``design = optimised``: a Gaussian-like density whose logarithm is a spline through a few
    knots, and a light Tukey taper, optimised for the lowest peak sidelobe at 2x oversampling
    and time-bandwidth product 180 (3.6 MHz x 50 us) and shipped as data; other products
    keep the shape, not the optimum (a note says so). ``taper_fraction`` overrides the
    design's taper.
    """

    design = Param(
        "gaussian",
        type="str",
        choices=("gaussian", "optimised"),
        doc="frequency law: Gaussian density, or the shipped optimised design",
    )
    density_std_fraction = Param(
        0.15,
        min=0.01,
        max=10.0,
        doc="Gaussian design: density standard deviation over the bandwidth",
    )
    taper_fraction = Param(
        None,
        min=0.0,
        max=1.0,
        optional=True,
        doc="Tukey amplitude taper, fraction in the edges (default: gaussian 0, optimised its own)",
    )

    def load(self) -> Any:
        if self.p["design"] == "optimised":
            from .nlfm import load_optimised

            return load_optimised()
        return None

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        from .nlfm import gaussian_log_density, optimised_envelope, stationary_phase

        band, width, fs = self.p["bandwidth_hz"], self.p["width_s"], self.rate()
        taper = self.p["taper_fraction"]
        if self.p["design"] == "gaussian":
            sigma = self.p["density_std_fraction"]
            env = stationary_phase(band, width, fs, gaussian_log_density(sigma), taper or 0.0)
            return {"pulse": self.dataset(env, f"nlfm, Gaussian density {sigma:g} B")}
        design = chunk.resource
        if design is None:
            raise ValueError("the optimised design was not loaded (load() reads it)")
        tb = band * width
        if abs(tb / design["time_bandwidth"] - 1) > 0.05:
            import warnings

            warnings.warn(
                f"the optimised NLFM was designed for a time-bandwidth product of "
                f"{design['time_bandwidth']:g}; at {tb:g} its sidelobes differ from the design's "
                f"{design['peak_sidelobe_db']:.1f} dB (check with `pasim waveform`)",
                RunNote,
                stacklevel=2,
            )
        env = optimised_envelope(design, band, width, fs, taper)
        return {"pulse": self.dataset(env, "nlfm, optimised")}


class FileWaveform(Block):
    """A waveform read from a NumPy ``.npz`` file (e.g. a measured or designed pulse).

    The file holds ``envelope`` (1-D complex baseband samples, at least 2) and
    ``sample_rate_hz`` (a positive scalar), and may hold ``bandwidth_hz``; write one with
    ``numpy.savez(path, envelope=env, sample_rate_hz=fs)``. The envelope is scaled to peak
    amplitude 1 (the transmitter's peak power); its shape and phase are kept.
    """

    pulse = Output(PULSE, doc="transmit envelope, peak amplitude 1")

    path = Param(None, type="path", doc=".npz file with envelope and sample_rate_hz")

    def load(self) -> Any:
        path = self.p["path"]
        try:
            with np.load(path, allow_pickle=False) as data:
                contents = {k: np.asarray(data[k]) for k in data.files}
        except Exception as exc:
            raise ValueError(
                f"cannot read waveform file {path!r} as .npz ({type(exc).__name__}: {exc})"
            ) from None
        for key in ("envelope", "sample_rate_hz"):
            if key not in contents:
                raise ValueError(
                    f"waveform file {path!r} has no {key!r} (holds: "
                    f"{', '.join(sorted(contents)) or 'nothing'}); expected envelope and "
                    "sample_rate_hz"
                )
        env, rate = contents["envelope"], contents["sample_rate_hz"]
        if env.ndim != 1 or env.size < 2 or not np.issubdtype(env.dtype, np.number):
            raise ValueError(
                f"waveform file {path!r}: envelope must be a 1-D array of at least 2 numbers, "
                f"found shape {env.shape} dtype {env.dtype}"
            )
        if not np.all(np.isfinite(env)) or not np.any(env != 0):
            raise ValueError(f"waveform file {path!r}: envelope must be finite and not all zero")
        if rate.size != 1 or not np.isfinite(float(rate)) or float(rate) <= 0:
            raise ValueError(
                f"waveform file {path!r}: sample_rate_hz must be one positive number, found {rate}"
            )
        out = {"envelope": env.astype(np.complex128), "sample_rate_hz": float(rate)}
        if "bandwidth_hz" in contents:
            out["bandwidth_hz"] = float(contents["bandwidth_hz"])
        return out

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        data = chunk.resource
        if data is None:
            raise ValueError("the waveform file was not loaded (load() reads it)")
        env, fs = data["envelope"], data["sample_rate_hz"]
        extra = {"bandwidth_hz": data["bandwidth_hz"]} if "bandwidth_hz" in data else {}
        name = f"file {self.p['path']}"
        return {
            "pulse": pulse_dataset(
                env / np.max(np.abs(env)), fs, waveform=name, width_s=env.size / fs, **extra
            )
        }
