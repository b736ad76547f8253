"""An antenna block's beam measured as an antenna engineer would (``pasim pattern`` and the
study's antenna figures).

Azimuth and elevation cuts through the beam (one-way, H and V, co- and cross-polar), the
3-dB beamwidths, first and peak sidelobes, peak gain, the peak cross-polar level in the main
beam and the two-way H/V ratio at the peak (the ZDR bias the pattern causes), of one beam
(:func:`measure`, :func:`measure_as_built`) or of a list of beam directions such as a scan's
(:func:`measure_beams`). Only the methods of :class:`~.antenna.Antenna` are called, so any
antenna deriving from it is measured alike.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from .antenna import Antenna
from .measures import first_sidelobe_db as cut_first_sidelobe_db
from .measures import half_power_beamwidth_deg, peak_sidelobe_db

#: Main beam for the cross-polar level: where the port's co-polar power is within this of its
#: peak (dB).
MAIN_BEAM_DB = 20.0


def antenna_blocks(graph: Any) -> list[str]:
    """Names of the graph's blocks that output an antenna pattern."""
    return sorted(
        name
        for name, cls in graph.classes.items()
        if any(port.type.kind == "pattern" for port in cls.outputs.values())
    )


def build(graph: Any, name: str, **overrides: Any) -> Antenna:
    """The antenna block ``name`` of ``graph``, built with its parameters and ``overrides``
    (a ValueError when the block is not an :class:`~.antenna.Antenna`)."""
    cls = graph.classes[name]
    if not issubclass(cls, Antenna):
        raise ValueError(
            f"block {name!r} ({cls.type_name}) is not a pasim_blocks.antennas.antenna.Antenna: "
            "its pattern cannot be evaluated at any direction"
        )
    return cls(name=name, **{**graph.params[name], **overrides})


def measure(
    block: Antenna,
    steer_az_deg: float,
    steer_el_deg: float,
    *,
    seed: int = 0,
    resource: Any = None,
    span_deg: float = 90.0,
    step_deg: float | None = None,
) -> dict[str, Any]:
    """Cuts and figures of merit of ``block``'s beam steered (az, el) from its broadside."""
    block.prepare(resource)
    az0, el0 = block.broadside()
    az_b, el_b = az0 + steer_az_deg, el0 + steer_el_deg
    step = step_deg or min(0.01, span_deg / 2000)
    d = np.arange(-span_deg, span_deg + step / 2, step)
    d_el = d[(el_b + d > -90) & (el_b + d < 90)]

    def cut(az: np.ndarray, el: np.ndarray) -> dict[str, np.ndarray]:
        f = block.fields_at(az_b, el_b, az, el, seed, resource)
        return {k: np.abs(np.asarray(getattr(f, k))) ** 2 for k in f._fields}

    az_cut = cut(az_b + d, np.full(d.size, el_b))
    el_cut = cut(np.full(d_el.size, az_b), el_b + d_el)
    bw_az = half_power_beamwidth_deg(d, az_cut["h_co"])
    bw_el = half_power_beamwidth_deg(d_el, el_cut["h_co"])
    # The main beam in 2-D, for the peak gain, the cross-polar level and the H/V ratio (the
    # geometric cross-polar field vanishes in the principal cuts).
    half = 1.5 * max(bw_az, bw_el)
    g = np.linspace(-half, half, 61)
    f = block.fields_at(az_b, el_b, az_b + g[None, :], el_b + g[:, None], seed, resource)
    shape = (g.size, g.size)
    power = {k: np.broadcast_to(np.abs(np.asarray(getattr(f, k))) ** 2, shape) for k in f._fields}
    peak = np.unravel_index(int(np.argmax(power["h_co"])), shape)
    cross = []
    for co, x in (("h_co", "h_cross"), ("v_co", "v_cross")):
        main = power[co] >= power[co].max() * 10 ** (-MAIN_BEAM_DB / 10)
        cross.append(float(power[x][main].max() / power[co].max()))
    gain_db = float(block.pattern_gain_db(resource))
    with np.errstate(divide="ignore"):
        result = {
            "beamwidth_az_deg": bw_az,
            "beamwidth_el_deg": bw_el,
            "first_sidelobe_db": first_sidelobe_db(d, az_cut["h_co"]),
            "first_sidelobe_el_db": first_sidelobe_db(d_el, el_cut["h_co"]),
            "peak_sidelobe_db": max(
                peak_sidelobe_db(d, az_cut["h_co"]), peak_sidelobe_db(d_el, el_cut["h_co"])
            ),
            "peak_gain_dbi": gain_db + float(10 * np.log10(power["h_co"][peak])),
            "cross_pol_db": float(10 * np.log10(max(cross))),
            "zdr_bias_db": float(20 * np.log10(power["h_co"][peak] / power["v_co"][peak])),
            "beamwidth_az_v_deg": half_power_beamwidth_deg(d, az_cut["v_co"]),
            "first_sidelobe_v_db": first_sidelobe_db(d, az_cut["v_co"]),
            "peak_sidelobe_v_db": max(
                peak_sidelobe_db(d, az_cut["v_co"]), peak_sidelobe_db(d_el, el_cut["v_co"])
            ),
            "cross_pol_h_db": float(10 * np.log10(cross[0])),
            "cross_pol_v_db": float(10 * np.log10(cross[1])),
            "gain_db": gain_db,
            "beam_azimuth_deg": float(az_b % 360.0),
            "beam_elevation_deg": float(el_b),
        }
    result["cuts"] = {"azimuth": (d, az_cut), "elevation": (d_el, el_cut)}  # type: ignore[assignment]
    return result


def measure_as_built(
    block: Antenna,
    steer_az_deg: float,
    steer_el_deg: float,
    *,
    seed: int = 0,
    span_deg: float = 90.0,
) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """:func:`measure` of the antenna as built (channel errors drawn from ``seed``) and of its
    ideal copy (None when its electronics are ideal), its resource loaded once for both."""
    resource = block.load()
    built = measure(
        block, steer_az_deg, steer_el_deg, seed=seed, resource=resource, span_deg=span_deg
    )
    twin = block.ideal_copy()
    ideal = (
        None
        if twin is None
        else measure(
            twin, steer_az_deg, steer_el_deg, seed=seed, resource=resource, span_deg=span_deg
        )
    )
    return built, ideal


def measure_beams(
    block: Antenna,
    beams: Iterable[tuple[float, float]],
    *,
    seed: int = 0,
    span_deg: float = 90.0,
) -> list[dict[str, Any]]:
    """:func:`measure` of ``block``'s beam steered to each absolute (azimuth, elevation) of
    ``beams`` (degrees, in the radar's frame, as a scan lists them), its resource loaded
    once: per beam, the figures (without the cuts) with ``azimuth_deg`` and ``elevation_deg``
    the beam's direction and ``steer_deg`` the offsets from broadside it was steered by."""
    resource = block.load()
    block.prepare(resource)
    rows = []
    for az, el in beams:
        steer = steer_from_broadside(block, az, el)
        figures = measure(block, *steer, seed=seed, resource=resource, span_deg=span_deg)
        del figures["cuts"]
        rows.append({"azimuth_deg": az, "elevation_deg": el, "steer_deg": list(steer), **figures})
    return rows


def steer_from_broadside(block: Antenna, az_deg: float, el_deg: float) -> tuple[float, float]:
    """The (azimuth, elevation) offsets from ``block``'s broadside of the absolute direction
    (``az_deg``, ``el_deg``), the azimuth wrapped into [-180, 180)."""
    az0, el0 = block.broadside()
    return (az_deg - az0 + 180.0) % 360.0 - 180.0, el_deg - el0


def first_sidelobe_db(angles_deg: np.ndarray, power: np.ndarray) -> float:
    """The first sidelobe of a cut, NaN when the cut holds none (too short a span)."""
    try:
        return cut_first_sidelobe_db(angles_deg, power)
    except ValueError:
        return float("nan")
