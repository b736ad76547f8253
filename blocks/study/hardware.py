"""A study system's hardware as a design review reads it: the antenna pattern of the beam at
the sector's centre, the waveform's range response through the graph's amplifiers and filter,
and the radiated spectrum against the NTIA RSEC emission mask.

Measured once per system (at its unswept graph) through the same public functions as
``pasim pattern``, ``pasim waveform`` and ``pasim spectrum``, so the report's figures are the
commands' figures. Kept as plain JSON in the study's manifest (curves thinned to a few hundred
points, keeping each bin's highest value so no sidelobe peak is lost); a part the graph cannot
give (no antenna with a pattern, no fast-time chain) is left out with the reason.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

#: Points kept of each curve (the largest value of each bin, so peaks survive thinning).
CURVE_POINTS = 600
#: Half-width of the pattern cut drawn (deg): the main lobe, the near and the far sidelobes.
#: (measured at ``pasim pattern``'s own step for that span, so its figures are the command's.)
PATTERN_SPAN_DEG = 60.0
#: The range response is drawn over this many range resolutions either side of the peak.
RESPONSE_SPAN_RESOLUTIONS = 15.0
#: Figures kept from each command's metrics (the rest are in the commands' own output).
PATTERN_KEYS = (
    "beamwidth_az_deg",
    "beamwidth_el_deg",
    "peak_sidelobe_db",
    "first_sidelobe_db",
    "peak_gain_dbi",
    "cross_pol_db",
    "zdr_bias_db",
    "beam_azimuth_deg",
    "beam_elevation_deg",
)
WAVEFORM_KEYS = (
    "waveforms",
    "amplifiers",
    "pulse_width_s",
    "bandwidth_hz",
    "psl_db",
    "psl_ideal_db",
    "isl_db",
    "range_resolution_m",
    "blind_range_m",
    "snr_loss_db",
    "power_efficiency",
    "power_efficiency_radiated",
)
SPECTRUM_KEYS = (
    "category",
    "peak_power_w",
    "bandwidth_40_hz",
    "bandwidth_40_allowed_hz",
    "criterion",
    "passes",
    "margin_db",
    "rise_time_s",
    "fall_time_s",
)


def thin(x: np.ndarray, *ys: np.ndarray, points: int = CURVE_POINTS) -> list[list[float]]:
    """``x`` and each ``y`` cut to at most ``points`` bins, each bin's largest ``y`` kept."""
    x = np.asarray(x, dtype=np.float64)
    if x.size <= points:
        return [_finite(x)] + [_finite(np.asarray(y, dtype=np.float64)) for y in ys]
    edges = np.linspace(0, x.size, points + 1).astype(int)
    out_x: list[float] = []
    out_y: list[list[float]] = [[] for _ in ys]
    for lo, hi in itertools.pairwise(edges):
        first = np.asarray(ys[0][lo:hi], dtype=np.float64)
        i = lo + int(np.nanargmax(first)) if np.isfinite(first).any() else lo
        out_x.append(float(x[i]))
        for k, y in enumerate(ys):
            out_y[k].append(float(np.nanmax(np.asarray(y[lo:hi], dtype=np.float64))))
    return [_finite(np.array(out_x))] + [_finite(np.array(y)) for y in out_y]


def _finite(a: np.ndarray) -> list[float]:
    """JSON-able values rounded to what a figure shows; -inf dB (a null) floored at -300."""
    return [round(float(v), 4) for v in np.nan_to_num(a, nan=-300.0, neginf=-300.0, posinf=300.0)]


def _db(p: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(np.asarray(p, dtype=np.float64))


def pattern_part(graph: Any, azimuth_deg: float, elevation_deg: float, seed: int) -> dict:
    """The beam at ``azimuth_deg``: its figures and its azimuth cut (H and V, dB of the
    peak)."""
    from ..antennas.beam_figures import measure, steer_from_broadside
    from .patterns import antenna

    built = antenna(graph)
    if built is None:
        return {"missing": "no antenna block of the graph evaluates its pattern"}
    block, resource = built
    steer = steer_from_broadside(block, azimuth_deg, elevation_deg)
    m = measure(
        block,
        *steer,
        seed=seed,
        resource=resource,
        span_deg=PATTERN_SPAN_DEG,
    )
    d, cut = m["cuts"]["azimuth"]
    peak = max(float(np.max(cut["h_co"])), float(np.max(cut["v_co"])))
    x, h, v = thin(d, _db(cut["h_co"] / peak), _db(cut["v_co"] / peak))
    return {
        "antenna": block.name,
        "figures": {k: m[k] for k in PATTERN_KEYS},
        "cut_deg": x,
        "h_db": h,
        "v_db": v,
    }


def waveform_part(graph: Any) -> dict:
    """The range response through the graph's amplifiers and filter, and its figures."""
    from ..waveforms.chain import ChainError, analyse

    try:
        a = analyse(graph)
    except ChainError as exc:
        return {"missing": str(exc)}
    out: dict[str, Any] = {"figures": {k: a.metrics.get(k) for k in WAVEFORM_KEYS}}
    span = RESPONSE_SPAN_RESOLUTIONS * max(
        a.metrics["range_resolution_m"], a.metrics["range_resolution_ideal_m"]
    )
    for name, response in (("actual", a.actual), ("ideal", a.ideal)):
        x = response["offset_m"].values
        p = np.abs(response["voltage"].values) ** 2
        keep = np.abs(x) <= span
        xs, ys = thin(x[keep], _db(p[keep] / p.max()))
        out[f"{name}_offset_m"], out[f"{name}_db"] = xs, ys
    return out


def spectrum_part(graph: Any) -> dict:
    """The radiated spectrum with the RSEC mask, and the verdict with its margin."""
    from ..transmitters.radiated import analyse
    from ..waveforms.chain import ChainError

    try:
        s = analyse(graph)
    except ChainError as exc:
        return {"missing": str(exc)}
    m = s.metrics
    reach = (
        1.2
        * m["bandwidth_40_allowed_hz"]
        / 2
        * 10 ** ((m["spurious_db"] - 40) / m["rolloff_db_per_decade"])
    )
    keep = np.abs(s.freq_hz) <= reach
    f, radiated, mask = thin(s.freq_hz[keep], s.radiated_db[keep], s.mask_db[keep])
    return {
        "figures": {k: m.get(k) for k in SPECTRUM_KEYS},
        "spurious_db": m["spurious_db"],
        "freq_hz": f,
        "radiated_db": radiated,
        "mask_db": mask,
    }


def system_hardware(graph: Any, azimuth_deg: float, elevation_deg: float, seed: int) -> dict:
    """The three parts of one system (JSON-able); each part says when it is missing."""
    parts = {}
    for key, make in (
        ("pattern", lambda: pattern_part(graph, azimuth_deg, elevation_deg, seed)),
        ("waveform", lambda: waveform_part(graph)),
        ("spectrum", lambda: spectrum_part(graph)),
    ):
        try:
            parts[key] = make()
        except (ValueError, RuntimeError) as exc:  # a part that cannot be measured is said
            parts[key] = {"missing": f"{type(exc).__name__}: {exc}"}
    return parts


def sector_middle(sector: tuple[float, float]) -> float:
    span = (sector[1] - sector[0]) % 360.0 or 360.0
    return (sector[0] + span / 2) % 360.0


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
