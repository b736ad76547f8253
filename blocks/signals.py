"""Port types shared by the block library, and physical constants.

Blocks connect only when their port types agree in kind, dtype, dimensions and units, so the
library declares each signal once here and every block uses the same declaration.
"""

from __future__ import annotations

from pasim_graph import DATASET, PortType

SPEED_OF_LIGHT = 299_792_458.0  # m/s
BOLTZMANN = 1.380_649e-23  # J/K
T0_K = 290.0  # reference temperature of the noise figure
KW2 = 0.93  # |K_w|^2 of liquid water at S band, as NEXRAD uses

#: The truth fields on their own polar grid (the whole sweep; radial x gate).
TRUTH = PortType("truth_sweep", DATASET, ("radial", "gate"), "cfradial")
#: Beam geometry of a chunk: azimuth, elevation, time, PRT and pulses per dwell.
BEAMS = PortType("beams", DATASET, ("beam",), "deg")
#: A sampled complex envelope (transmit pulse or reference), with its sample rate.
PULSE = PortType("pulse", DATASET, ("sample",), "sqrt(W)")
#: Range weighting after the matched filter: power weight against range offset.
RANGE_RESPONSE = PortType("range_response", DATASET, ("offset",), "1")
#: One-way power patterns per beam and polarisation on an angular grid around the beam axis.
PATTERN = PortType(
    "pattern", DATASET, ("beam", "polarization", "elevation_offset", "azimuth_offset"), "1"
)
#: The I/Q cube of a chunk of beams.
IQ = PortType("iq", "complex64", ("beam", "range", "pulse", "polarization"), "sqrt(W)")
#: The H and V I/Q cubes as stored in the output volume.
IQ_CUBE = PortType("iq_cube", DATASET, ("beam", "range", "pulse"), "sqrt(W)")
#: Expected (noise-free) signal power per gate and polarisation.
SIGNAL_POWER = PortType("signal_power", "float32", ("beam", "range", "polarization"), "W")
#: Expected (noise-free) correlations of the echo per gate: lag-0 and lag-1 of H and V and the
#: lag-0 H-V cross-correlation E[h* v], in the order of CORRELATION_PRODUCTS.
ECHO_CORRELATIONS = PortType(
    "echo_correlations", "complex128", ("beam", "range", "correlation"), "W"
)
#: Receiver noise power per gate and polarisation, at the matched-filter output.
NOISE_POWER = PortType("noise_power", "float64", ("beam", "range", "polarization"), "W")
#: Radar constant per beam and polarisation, with the gate ranges.
CALIBRATION = PortType("calibration", DATASET, ("beam", "range", "polarization"), "dB")
#: Estimated moments on the beam x range grid, CfRadial names and attributes.
MOMENTS = PortType("moments", DATASET, ("beam", "range"), "cfradial")
#: Errors of each moment against truth, for the scores.
SCORES = PortType("scores", DATASET, ("beam", "range"), "cfradial")

POLARIZATIONS = ("H", "V")
CORRELATION_PRODUCTS = ("R0_H", "R0_V", "R1_H", "R1_V", "R0_HV")
#: The moments a pulse-pair processor estimates, CfRadial names.
MOMENT_FIELDS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
POLARIMETRIC_FIELDS = ("ZDR", "RHOHV", "PHIDP")
