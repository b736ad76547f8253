"""Port types shared by the block library, and physical constants.

Blocks connect only when their port types agree in kind, dtype, dimensions and units, so the
library declares each signal once here and every block uses the same declaration.
"""

from __future__ import annotations

from typing import Any

from pasim_graph import DATASET, Attr, Chunk, PortType, Schema, Var
from pasim_graph.fm301 import MOMENT_DOCS, MOMENT_UNITS

SPEED_OF_LIGHT = 299_792_458.0  # m/s
BOLTZMANN = 1.380_649e-23  # J/K
T0_K = 290.0  # reference temperature of the noise figure
KW2 = 0.93  # |K_w|^2 of liquid water at S band, as NEXRAD uses


def _moments(dims: tuple[str, ...], required: tuple[str, ...] = (), prefix: str = "") -> dict:
    return {
        f"{prefix}{k}": Var("float32", dims, u, MOMENT_DOCS[k], required=k in required)
        for k, u in MOMENT_UNITS.items()
    }


_SITE = {
    "latitude": Attr("float", "site latitude (deg north)"),
    "longitude": Attr("float", "site longitude (deg east)"),
    "altitude": Attr("float", "site altitude (m)"),
}

#: The truth fields on their own polar grid (the whole sweep; radial x gate). Only DBZH is
#: required: a legacy single-polarisation file has no ZDR, RHOHV, PHIDP.
TRUTH = PortType(
    "truth_sweep",
    DATASET,
    ("radial", "gate"),
    "cfradial",
    Schema(
        {
            **_moments(("radial", "gate"), required=("DBZH",)),
            "azimuth": Var("float64", ("radial",), "degrees", "radial azimuths, clockwise"),
            "range": Var("float64", ("gate",), "meters", "gate centre ranges"),
            # A volume truth (truth.sweeps = volume): every sweep read, on the same grid.
            **_moments(("sweep", "radial", "gate"), prefix="volume_"),
            "sweep_elevation": Var(
                "float64",
                ("sweep",),
                "degrees",
                "elevation of each sweep of a volume truth",
                required=False,
            ),
            "height": Var(
                "float64", ("sweep", "gate"), "meters", "beam height (4/3 earth)", required=False
            ),
            # A truth that carries its wind (truth.grid from u, v, w): east, north, up.
            **{
                f"volume_{k}_wind": Var(
                    "float32",
                    ("sweep", "radial", "gate"),
                    "m s-1",
                    f"{k} wind at each gate of a volume truth",
                    required=False,
                )
                for k in ("eastward", "northward", "upward")
            },
        },
        {
            "elevation_deg": Attr("float", "elevation of the sweep"),
            "elevation_interpolation": Attr(
                "str", "volume truth: linear or nearest in elevation", required=False
            ),
            "sweep_beamwidth_deg": Attr(
                "float", "volume truth: elevations each sweep stands for", required=False
            ),
            "radial_width_deg": Attr("float", "azimuth spacing of the radials"),
            "gate_width_m": Attr("float", "range spacing of the gates"),
            "nyquist_velocity_ms": Attr("float", "Nyquist velocity of the truth (NaN: none)"),
            "polarimetric": Attr("int", "1 when ZDR, RHOHV and PHIDP are all present"),
            "source": Attr("str", "where the truth came from"),
            "instrument_name": Attr("str", "radar that measured it"),
            "time_coverage_start": Attr("str", "ISO time of the sweep start"),
            **_SITE,
        },
    ),
)
#: Beam geometry of a chunk: azimuth, elevation, time, PRT and pulses per dwell.
BEAMS = PortType(
    "beams",
    DATASET,
    ("beam",),
    "deg",
    Schema(
        {
            "azimuth": Var("float64", ("beam",), "degrees", "beam azimuth, clockwise from north"),
            "elevation": Var("float64", ("beam",), "degrees", "beam elevation"),
            "time": Var("datetime64", ("beam",), "", "start of each dwell"),
            "prt": Var("float64", ("beam",), "seconds", "pulse repetition time (T1 if staggered)"),
            "prt_ratio": Var(
                "float64",
                ("beam",),
                "1",
                "T1 / T2 of a staggered PRT (absent: uniform)",
                required=False,
            ),
            "transmit_phase": Var(
                "float64",
                ("beam", "pulse"),
                "radians",
                "transmit phase of each pulse of a phase-coded scan (absent: none)",
                required=False,
            ),
            # What the transmitter puts on the code besides its phase (scan.ppi's
            # phase_code_error_deg and phase_code_ripple_db): the echoes carry them, the
            # processors decode with transmit_phase alone.
            "transmit_phase_error": Var(
                "float64",
                ("beam", "pulse"),
                "radians",
                "error of each coded pulse's transmitted phase (absent: none)",
                required=False,
            ),
            "transmit_amplitude": Var(
                "float64",
                ("beam", "pulse"),
                "1",
                "voltage amplitude of each coded pulse over the nominal (absent: 1)",
                required=False,
            ),
            "scan_rate": Var(
                "float64", ("beam",), "degrees/s", "azimuth rate of the scan", required=False
            ),
            # A scan on a platform (scan.ppi's platform): the array-frame steering, the
            # platform's attitude and velocity at each dwell, and that velocity on the beam.
            **{
                name: Var("float64", ("beam",), units, doc, required=False)
                for name, units, doc in (
                    ("array_azimuth", "degrees", "azimuth steered in the array frame"),
                    ("array_elevation", "degrees", "elevation steered in the array frame"),
                    ("heading", "degrees", "platform heading"),
                    ("pitch", "degrees", "platform pitch"),
                    ("roll", "degrees", "platform roll"),
                    ("eastward_velocity", "m s-1", "platform velocity east"),
                    ("northward_velocity", "m s-1", "platform velocity north"),
                    ("vertical_velocity", "m s-1", "platform velocity up"),
                    (
                        "platform_radial_velocity",
                        "m s-1",
                        "platform velocity along the beam (toward the target)",
                    ),
                )
            },
            "pulses": Var("integer", (), "", "pulses per dwell (M)"),
            "sweep_number": Var("integer", (), "", "sweep index in the volume"),
            "sweep_mode": Var("str", (), "", "CfRadial sweep mode"),
            "sweep_fixed_angle": Var("float64", (), "degrees", "nominal elevation"),
            "prt_mode": Var("str", (), "", "FM-301 PRT mode: fixed, staggered or dual"),
            "follow_mode": Var("str", (), "", "FM-301 follow mode (none: a ground radar)"),
            "time_coverage_start": Var("str", (), "", "ISO time of the scan start"),
            "time_coverage_end": Var("str", (), "", "ISO time of the scan end"),
            "volume_number": Var("integer", (), "", "volume index"),
            "platform_type": Var("str", (), "", "CfRadial platform type"),
            "instrument_type": Var("str", (), "", "CfRadial instrument type"),
            "latitude": Var("float64", (), "degrees_north", "site latitude"),
            "longitude": Var("float64", (), "degrees_east", "site longitude"),
            "altitude": Var("float64", (), "meters", "site altitude"),
        }
    ),
)
#: A sampled complex envelope (transmit pulse or reference), with its sample rate.
PULSE = PortType(
    "pulse",
    DATASET,
    ("sample",),
    "sqrt(W)",
    Schema(
        {
            "envelope": Var("complex128", ("sample",), "1", "complex envelope, 1 = peak power"),
            "time": Var("float64", ("sample",), "s", "sample times from the pulse start"),
        },
        {
            "sample_rate_hz": Attr("float", "sample rate of the envelope"),
            "waveform": Attr("str", "name of the waveform", required=False),
            "width_s": Attr("float", "pulse length", required=False),
            "bandwidth_hz": Attr("float", "swept bandwidth", required=False),
            "power_divider_ports": Attr(
                "int", "ports a power divider split the transmitter between", required=False
            ),
            "power_divider_loss_db": Attr("float", "that divider's loss", required=False),
        },
    ),
)
#: The receive filter and what it makes of the radiated pulse: the range response a gate sees
#: (the filter output for a point target against range offset), the radiated pulse and the
#: filter's impulse response, all at one sample rate.
RANGE_RESPONSE = PortType(
    "range_response",
    DATASET,
    ("offset",),
    "1",
    Schema(
        {
            "voltage": Var(
                "complex128", ("offset",), "1", "filter output for a point target, y(offset)"
            ),
            "power_weight": Var("float64", ("offset",), "1", "|y|^2, the range weighting"),
            "offset_m": Var("float64", ("offset",), "m", "range offset beyond the gate"),
            "transmitted": Var(
                "complex128", ("sample",), "1", "radiated envelope (1 = peak power)"
            ),
            "taps": Var(
                "complex128", ("tap",), "1", "receive filter impulse response, at sample_rate_hz"
            ),
        },
        {
            "sample_rate_hz": Attr("float", "sample rate of pulse, taps and offsets"),
            "noise_bandwidth_hz": Attr("float", "noise bandwidth of the filter (fs sum|h|^2)"),
            "blind_range_m": Attr("float", "range hidden while transmitting (c T / 2)"),
            "snr_loss_db": Attr(
                "float",
                "loss of peak SNR against the filter matched to the radiated pulse",
                required=False,
            ),
            "power_divider_ports": Attr(
                "int", "the radiated pulse's power divider: ports", required=False
            ),
            "power_divider_loss_db": Attr(
                "float", "the radiated pulse's power divider: loss", required=False
            ),
        },
    ),
)
#: One-way power patterns per beam and polarisation on an angular grid around the beam axis.
PATTERN = PortType(
    "pattern",
    DATASET,
    ("beam", "polarization", "elevation_offset", "azimuth_offset"),
    "1",
    Schema(
        {
            "power": Var(
                "floating",
                ("beam", "polarization", "elevation_offset", "azimuth_offset"),
                "1",
                "one-way power pattern over the peak gain",
            ),
            "calibration_solid_angle_sr": Var(
                "float64",
                ("beam", "polarization"),
                "sr",
                "two-way solid angle the radar constant of each beam is computed with",
            ),
            "co_polar": Var(
                "complex64",
                ("beam", "polarization", "elevation_offset", "azimuth_offset"),
                "1",
                "one-way co-polar voltage pattern of the H (h) and V (v) port; |.|^2 = power",
                required=False,
            ),
            "cross_polar": Var(
                "complex64",
                ("beam", "polarization", "elevation_offset", "azimuth_offset"),
                "1",
                "one-way cross-polar voltage pattern: the H port's v, the V port's h component",
                required=False,
            ),
            "polarization": Var("str", ("polarization",), "", "H, V"),
            "azimuth_offset_deg": Var(
                "float64", ("azimuth_offset",), "degrees", "azimuth offset from the beam axis"
            ),
            "elevation_offset_deg": Var(
                "float64", ("elevation_offset",), "degrees", "elevation offset from the axis"
            ),
        },
        {
            "gain_db": Attr("float", "peak gain (dBi)"),
            "two_way_solid_angle_sr_H": Attr("float", "boresight two-way solid angle, H (sr)"),
            "two_way_solid_angle_sr_V": Attr("float", "boresight two-way solid angle, V (sr)"),
            "antenna": Attr("str", "antenna model"),
            "calibration": Attr("str", "how beams are calibrated: boresight or per_beam"),
        },
    ),
)
#: The I/Q cube of a chunk of beams.
IQ = PortType("iq", "complex64", ("beam", "range", "pulse", "polarization"), "sqrt(W)")
#: The H and V I/Q cubes as stored in the output volume.
IQ_CUBE = PortType(
    "iq_cube",
    DATASET,
    ("beam", "range", "pulse"),
    "sqrt(W)",
    Schema(
        {
            f"IQ_{p}": Var("complex64", ("beam", "range", "pulse"), "sqrt(W)", f"{p} channel I/Q")
            for p in ("H", "V")
        }
    ),
)
#: Expected (noise-free) signal power per gate and polarisation.
SIGNAL_POWER = PortType("signal_power", "float32", ("beam", "range", "polarization"), "W")
#: Expected (noise-free) correlations of the echo per gate, in the order of
#: CORRELATION_PRODUCTS: of the co-polar H and V series h, v (the H and V ports in SHV; in AHV
#: the H port on H-transmit pulses and the V port on V-transmit pulses, as if every pulse were
#: one), lags 0, 1 and 2 of each, E[h* v] at lag 0, and E[h_m* v_m+1], E[v_m* h_m+1] at lag 1
#: (one pulse apart). Lag 2 and the lag-1 H-V products serve the AHV estimators only; under
#: SHV they are NaN (not computed).
ECHO_CORRELATIONS = PortType(
    "echo_correlations", "complex128", ("beam", "range", "correlation"), "W"
)
#: Receiver noise power per gate and polarisation, at the matched-filter output.
NOISE_POWER = PortType("noise_power", "float64", ("beam", "range", "polarization"), "W")
#: Radar constant per beam and polarisation, with the gate ranges.
CALIBRATION = PortType(
    "calibration",
    DATASET,
    ("beam", "range", "polarization"),
    "dB",
    Schema(
        {
            "radar_constant_db": Var(
                "float64",
                ("beam", "polarization"),
                "dB",
                "10 log10 of echo power x r^2 for 1 mm^6 m^-3, per beam and channel",
            ),
            "overlaid_power_ratio_db": Var(
                "float32",
                ("beam", "range"),
                "dB",
                "expected power of the other trips over the gate's own (range folding)",
                required=False,
            ),
            "path_attenuation_db": Var(
                "float64",
                ("beam", "range", "polarization"),
                "dB",
                "two-way path attenuation along the beam's axis (propagation on)",
                required=False,
            ),
            "range": Var("float64", ("range",), "meters", "gate centre ranges"),
            "polarization": Var("str", ("polarization",), "", "H, V"),
        },
        {
            "wavelength_m": Attr("float", "radar wavelength"),
            "prt_s": Attr("float", "pulse repetition time"),
            "dual_polarization": Attr("int", "1 when the V channel carries an echo"),
            "blind_range_m": Attr("float", "gates nearer than this are not estimated"),
            "calibration": Attr("str", "how beams are calibrated: boresight or per_beam"),
            "transmission": Attr(
                "str",
                "shv (H and V every pulse) or ahv (H on even pulses, V on odd; both ports "
                "receive every pulse); absent: shv",
                required=False,
            ),
            "transmit_differential_phase_deg": Attr(
                "float", "phase of the V excitation against H in SHV (deg)", required=False
            ),
            "cross_polar_coupling": Attr(
                "int",
                "1 when the echoes were coupled through co- and cross-polar fields",
                required=False,
            ),
            "unambiguous_range_m": Attr(
                "float",
                "c T / 2 when echoes from beyond it fold onto the gates (range folding)",
                required=False,
            ),
            "transmit_power": Attr(
                "str",
                "the transmit power convention: per port, or a total through a power divider",
                required=False,
            ),
            "transmit_power_per_port_w": Attr(
                "float", "peak power radiated at each port (W)", required=False
            ),
        },
    ),
)
#: Estimated moments on the beam x range grid, CfRadial names and attributes.
MOMENTS = PortType(
    "moments",
    DATASET,
    ("beam", "range"),
    "cfradial",
    Schema(
        {
            **_moments(("beam", "range")),
            "range": Var("float64", ("range",), "meters", "gate centre ranges"),
            "nyquist_velocity": Var("float64", ("beam",), "m s-1", "Nyquist velocity"),
            "CCORH": Var(
                "float32",
                ("beam", "range"),
                "dB",
                "clutter power removed by the clutter filter, H (spectral processor)",
                required=False,
            ),
        },
        {
            "blind_range_m": Attr("float", "gates nearer than this are not estimated"),
            "calibration": Attr("str", "how beams were calibrated: boresight or per_beam"),
            "transmit_power": Attr(
                "str", "the transmit power convention (see CALIBRATION)", required=False
            ),
            "transmission": Attr("str", "shv or ahv (see CALIBRATION)", required=False),
            "phidp_period_deg": Attr(
                "float",
                "PHIDP is estimated modulo this: 360, or 180 with alternate transmission",
                required=False,
            ),
        },
    ),
)
#: Errors of each moment against truth, for the scores.
SCORES = PortType(
    "scores",
    DATASET,
    ("beam", "range"),
    "cfradial",
    Schema(
        {
            "SNRH": Var("float32", ("beam", "range"), "dB", "expected SNR, H (noise-free echo)"),
            "scored": Var("int8", ("beam", "range"), "", "1 where the gate meets the rule"),
            "overlaid": Var(
                "int8",
                ("beam", "range"),
                "",
                "1 where the gate meets the rule but is overlaid by other trips (not scored)",
                required=False,
            ),
            **_moments(("beam", "range"), prefix="truth_"),
            **{
                f"error_{k}": Var(
                    "float32", ("beam", "range"), u, f"{k} estimate minus truth", required=False
                )
                for k, u in MOMENT_UNITS.items()
            },
        }
    ),
)

POLARIZATIONS = ("H", "V")
CORRELATION_PRODUCTS = (
    "R0_H",
    "R0_V",
    "R1_H",
    "R1_V",
    "R0_HV",
    "R2_H",
    "R2_V",
    "R1_HV",
    "R1_VH",
)
#: The products an SHV processor uses (the first of CORRELATION_PRODUCTS).
SHV_PRODUCTS = CORRELATION_PRODUCTS[:5]


def check_pulses(iq: Any, chunk: Chunk, block: str) -> None:
    """Refuse an :data:`IQ` cube whose pulse axis contradicts the run's declared level.

    The level is ``chunk.expected`` (the engine's, from the blocks' fidelity declarations);
    blocks decide on it, not on the axis. At the expected level the cube has no pulses (a
    pulse axis of length 0, its true shape); otherwise it has some. A cube that disagrees
    (a block upstream drew pulses at the expected level, or none when time series are
    drawn) is a ValueError naming ``block``, not a guess either way.
    """
    pulses = int(iq.shape[2])
    if chunk.expected and pulses:
        raise ValueError(
            f"block '{block}': the run is at the expected level (the weather channel's "
            f"method 'expected' draws no pulses) but the I/Q cube has {pulses} pulses; run "
            "every weather channel of the graph at the same level"
        )
    if not chunk.expected and not pulses:
        raise ValueError(
            f"block '{block}': the I/Q cube has no pulses but the run is not at the expected "
            "level (the weather channel's method is not 'expected', so pulses are drawn); "
            "a block upstream returned an empty pulse axis"
        )
