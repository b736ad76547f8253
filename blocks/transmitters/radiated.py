"""The radiated pulse's spectrum against the NTIA RSEC mask (``pasim spectrum``, a study's
hardware page).

The transmit chain is found as :mod:`pasim_blocks.waveforms.chain` finds it (by port kinds:
the waveforms upstream of the receive filter, and the amplifiers that take and emit a pulse);
only the waveform and amplifier blocks run, through their public API, at an analysis sample
rate wide enough to see the mask down to its spurious level: the waveform blocks that have a
``sample_rate_hz`` parameter are re-run at that rate, so the envelope, the amplifier's
distortion and its rise and fall edges are sampled finely (a waveform without the parameter,
e.g. ``waveform.file``, is used at its own rate, and the span is limited to it). The drive
(every amplifier replaced by a wire) is computed too, for comparison.

The spectrum, the -40 dB bandwidth and the mask are those of :mod:`.emission` (whose
constants are unverified: see its docstring and docs/transceiver.md). The radar's category
(default D) and its peak power (a block parameter ``peak_power_w`` of the graph, or given)
choose the criteria; an FM waveform is one whose pulse carries a ``bandwidth_hz`` (its swept
bandwidth B_c).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from pasim_graph import Chunk, Graph

from ..waveforms.chain import PULSE_KIND, ChainError, find_chain
from .emission import (
    bandwidth_at,
    compliance,
    mask_db,
    mask_span_hz,
    power_spectrum,
    rise_fall_times,
    rsec_criteria,
)

#: The analysis span exceeds the mask's reach to the spurious level by this factor.
SPAN_MARGIN = 2.0
#: At most this many samples in the analysed pulse (bounds memory and time).
MAX_SAMPLES = 1 << 21


@dataclass
class Spectrum:
    """What ``pasim spectrum`` reports and plots."""

    metrics: dict[str, Any]
    drive: xr.Dataset  # the waveform through ideal amplifiers
    radiated: xr.Dataset  # through the graph's amplifiers
    freq_hz: np.ndarray
    radiated_db: np.ndarray
    drive_db: np.ndarray
    mask_db: np.ndarray


def transmit_pulses(graph: Graph, rate_hz: float | None) -> tuple[xr.Dataset, xr.Dataset, Any]:
    """The drive and the radiated pulse, the waveforms re-run at ``rate_hz`` (None: as is)."""
    chain = find_chain(graph)
    if not chain.amplifiers and len(chain.waveforms) != 1:
        raise ChainError(f"{len(chain.waveforms)} waveforms and no amplifier: which is radiated?")
    blocks = [n for n in chain.order if n in chain.waveforms or n in chain.amplifiers]
    out: dict[bool, dict[tuple[str, str], Any]] = {}
    for ideal in (True, False):
        values: dict[tuple[str, str], Any] = {}
        for name in blocks:
            cls = graph.classes[name]
            inputs = {e.dst_port: values[(e.src, e.src_port)] for e in graph.inputs_of(name)}
            if ideal and name in chain.amplifiers:
                result = {p.name: next(iter(inputs.values())) for p in cls.outputs.values()}
            else:
                params = dict(graph.params[name])
                if (
                    name in chain.waveforms
                    and rate_hz is not None
                    and "sample_rate_hz" in cls.params
                ):
                    params["sample_rate_hz"] = rate_hz
                what = f"block '{name}' ({cls.type_name})"
                try:
                    block = cls(name=name, **params)
                    result = block.process(
                        inputs,
                        Chunk(beams=np.arange(0), block_name=name, resource=block.load()),
                    )
                except Exception as exc:
                    raise ChainError(f"{what} failed: {type(exc).__name__}: {exc}") from None
            for port, value in result.items():
                values[(name, port)] = value
        out[ideal] = values
    # The radiated pulse: the output of the amplifier no other amplifier takes.
    last = [
        a
        for a in chain.amplifiers
        if not any(e.src == a and e.dst in chain.amplifiers for e in graph.edges)
    ]
    if len(last) > 1:
        raise ChainError(f"several final amplifiers ({', '.join(last)}): which is radiated?")
    source = last[0] if last else chain.waveforms[0]
    port = next(p.name for p in graph.classes[source].outputs.values() if p.type.kind == PULSE_KIND)
    # The drive: what the same stage emits when every amplifier is a wire.
    return out[True][(source, port)], out[False][(source, port)], chain


def graph_peak_power(graph: Graph) -> float | None:
    """The ``peak_power_w`` parameter of the graph's block that has one (None: none)."""
    found = [
        float(graph.params[n].get("peak_power_w", c.params["peak_power_w"].default))
        for n, c in graph.classes.items()
        if "peak_power_w" in c.params
    ]
    return found[0] if found else None


def _criteria_for(pulse: xr.Dataset, category: str, peak_w: float) -> tuple[Any, dict[str, Any]]:
    fs = float(pulse.attrs["sample_rate_hz"])
    env = pulse["envelope"].values
    rise, fall = rise_fall_times(env, fs)
    width = env.size / fs
    chirp = pulse.attrs.get("bandwidth_hz")
    crit = rsec_criteria(category, width, min(rise, fall), peak_w, chirp)
    return crit, {
        "width_s": width,
        "rise_time_s": rise,
        "fall_time_s": fall,
        "chirp_bandwidth_hz": chirp,
    }


def analyse(
    graph: Graph,
    category: str = "D",
    peak_power_w: float | None = None,
    rate_hz: float | None = None,
) -> Spectrum:
    """The radiated spectrum, its -40 dB bandwidth and the RSEC mask with the margin."""
    peak = peak_power_w if peak_power_w is not None else graph_peak_power(graph)
    if peak is None:
        raise ChainError("no block of the graph has a peak_power_w: give --peak-power-w")
    if rate_hz is None:
        # A first pass at the graph's own rates gives the criteria, hence the span needed.
        _, first, _ = transmit_pulses(graph, None)
        crit, _ = _criteria_for(first, category, peak)
        native = float(first.attrs["sample_rate_hz"])
        rate_hz = max(native, 2 * SPAN_MARGIN * mask_span_hz(crit))
        width = first["envelope"].size / native
        if width * rate_hz > MAX_SAMPLES:
            rate_hz = MAX_SAMPLES / width
    drive, radiated, chain = transmit_pulses(graph, rate_hz)
    crit, shape = _criteria_for(radiated, category, peak)
    fs = float(radiated.attrs["sample_rate_hz"])
    f, level = power_spectrum(radiated["envelope"].values, fs)
    _, drive_level = power_spectrum(drive["envelope"].values, float(drive.attrs["sample_rate_hz"]))
    measured = bandwidth_at(f, level)
    verdict = compliance(f, level, crit)
    metrics: dict[str, Any] = {
        "graph": graph.spec.file,
        "waveforms": chain.waveforms,
        "amplifiers": chain.amplifiers,
        "category": category,
        "peak_power_w": peak,
        "fm": shape["chirp_bandwidth_hz"] is not None,
        **shape,
        "analysis_sample_rate_hz": fs,
        "bandwidth_40_hz": measured["bandwidth_hz"],
        "bandwidth_40_low_hz": measured["low_hz"],
        "bandwidth_40_high_hz": measured["high_hz"],
        "bandwidth_40_allowed_hz": crit.bandwidth_40_hz,
        "criterion": crit.formula,
        "k": crit.k,
        "rolloff_db_per_decade": crit.slope_db_per_decade,
        "spurious_db": crit.spurious_db,
        "passes": verdict["passes"],
        "margin_db": verdict["margin_db"],
        "worst_offset_hz": verdict["worst_offset_hz"],
    }
    try:
        metrics["bandwidth_40_drive_hz"] = bandwidth_at(f, drive_level)["bandwidth_hz"]
    except ValueError:
        metrics["bandwidth_40_drive_hz"] = None
    return Spectrum(metrics, drive, radiated, f, level, drive_level, mask_db(f, crit))
