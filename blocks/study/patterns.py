"""A study system's antenna, measured beside its scores: the two-way H/V power ratio of every
beam of the scan and the peak sidelobe of the pattern as built.

Everything goes through the methods :class:`pasim_blocks.antennas.antenna.Antenna` declares,
as ``pasim pattern`` does (:func:`pasim_blocks.antennas.beam_figures.build` and
:func:`~pasim_blocks.antennas.beam_figures.measure`, ``fields_at`` at absolute directions),
with the channel errors the run seed draws. The figures
are plain JSON, kept in the study's manifest: computed once per system, case and sweep point.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Beams, spread evenly over the sector, whose peak sidelobe is measured (their spread gives
#: the interval: an impaired array's sidelobes differ from beam to beam).
SIDELOBE_BEAMS = 5
#: Half-width of the azimuth and elevation cuts the peak sidelobe is searched in, and their
#: step (fine against the narrowest beam of the paper's systems, 1 deg).
SIDELOBE_SPAN_DEG = 90.0
SIDELOBE_STEP_DEG = 0.02


def antenna(graph: Any) -> tuple[Any, Any] | None:
    """The graph's (first) antenna block, built and prepared, and its resource."""
    from ..antennas.beam_figures import antenna_blocks, build

    names = antenna_blocks(graph)
    if not names:
        return None
    try:
        block = build(graph, names[0])
    except ValueError:  # an antenna that cannot evaluate its pattern at any direction
        return None
    resource = block.load()
    block.prepare(resource)
    return block, resource


def hv_ratio_db(
    block: Any, resource: Any, azimuth_deg: np.ndarray, elevation_deg: float, seed: int
) -> np.ndarray:
    """The two-way H/V power ratio (dB) at each beam's own direction: the ZDR bias a beam
    has when the radar constant is the broadside one (paper section 3.3.2)."""
    out = []
    for az in np.asarray(azimuth_deg, dtype=np.float64):
        f = block.fields_at(
            float(az), elevation_deg, np.array([az]), np.array([elevation_deg]), seed, resource
        )
        h = float(np.abs(np.asarray(f.h_co)).ravel()[0]) ** 2
        v = float(np.abs(np.asarray(f.v_co)).ravel()[0]) ** 2
        out.append(20.0 * math.log10(h / v) if h > 0 and v > 0 else math.nan)
    return np.array(out)


def sample_beams(azimuth_deg: np.ndarray, n: int = SIDELOBE_BEAMS) -> np.ndarray:
    """``n`` of the scan's beams, evenly spread from its first to its last."""
    az = np.asarray(azimuth_deg, dtype=np.float64)
    if az.size <= n:
        return az
    return az[np.round(np.linspace(0, az.size - 1, n)).astype(int)]


def peak_sidelobes(
    block: Any, resource: Any, azimuth_deg: np.ndarray, elevation_deg: float, seed: int
) -> list[float]:
    """Peak sidelobe (dB below the beam's peak, H port, azimuth and elevation cuts) of each of
    the beams ``azimuth_deg``."""
    from ..antennas.beam_figures import measure, steer_from_broadside

    out = []
    for az in azimuth_deg:
        steer = steer_from_broadside(block, float(az), elevation_deg)
        figures = measure(
            block,
            *steer,
            seed=seed,
            resource=resource,
            span_deg=SIDELOBE_SPAN_DEG,
            step_deg=SIDELOBE_STEP_DEG,
        )
        out.append(float(figures["peak_sidelobe_db"]))
    return out


def point_patterns(graph: Any, azimuth_deg: np.ndarray, elevation_deg: float, seed: int) -> dict:
    """The antenna figures of one system, case and sweep point (JSON-able; empty when the
    graph's antenna cannot evaluate its pattern)."""
    from .intervals import t_interval

    built = antenna(graph)
    if built is None:
        return {}
    block, resource = built
    az0, el0 = block.broadside()
    beams = sample_beams(azimuth_deg)
    sidelobes = peak_sidelobes(block, resource, beams, elevation_deg, seed)
    finite = [s for s in sidelobes if math.isfinite(s)]
    calibration = (
        str(graph.value(block.name, "calibration"))
        if "calibration" in graph.classes[block.name].params
        else ""
    )
    return {
        "antenna": block.name,
        "calibration": calibration,
        "seed": seed,
        "azimuth_deg": [float(a) for a in azimuth_deg],
        "hv_ratio_db": [
            float(r) for r in hv_ratio_db(block, resource, azimuth_deg, elevation_deg, seed)
        ],
        # What the broadside radar constant corrects: the ratio at broadside.
        "hv_ratio_broadside_db": float(hv_ratio_db(block, resource, np.array([az0]), el0, seed)[0]),
        "sidelobe_beams_deg": [float(a) for a in beams],
        "peak_sidelobes_db": sidelobes,
        "peak_sidelobe_db": float(np.mean(finite)) if finite else math.nan,
        "peak_sidelobe_ci": t_interval(finite) if len(finite) > 1 else [math.nan, math.nan],
    }
