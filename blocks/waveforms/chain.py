"""A graph's fast-time chain: its pulse through its amplifiers and receive filter.

The chain is found from the graph's port kinds alone: the receive filter is the block with an
output of kind ``range_response``; the waveforms are the blocks upstream of it that emit a
``pulse`` and take none; the amplifiers are the blocks upstream of it that take a ``pulse``
and emit one. Only those blocks run (once: none of them may depend on beams), twice: as the
graph has them, and with every amplifier replaced by a wire (an ideal, linear transmitter).
From the two range responses :func:`analyse` gives the figures of merit of
:mod:`.compression` (``pasim waveform`` prints them, a study's hardware page shows them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import networkx as nx
import numpy as np
import xarray as xr

from pasim_graph import Chunk, Graph

from ..signals import SPEED_OF_LIGHT
from .compression import power_efficiency, sidelobes, snr_loss_db

PULSE_KIND = "pulse"
RESPONSE_KIND = "range_response"


class ChainError(Exception):
    """The graph has no usable fast-time chain (printed as a user error)."""


@dataclass
class Chain:
    """The blocks that make a graph's range response, found by port kinds."""

    filter: str
    order: list[str]  # upstream blocks and the filter, in run order
    waveforms: list[str]
    amplifiers: list[str]


def _kinds(ports: Any) -> set[str]:
    return {p.type.kind for p in ports.values()}


def find_chain(graph: Graph, filter_name: str | None = None) -> Chain:
    """The receive filter of ``graph`` and the blocks that feed it."""
    filters = sorted(n for n, c in graph.classes.items() if RESPONSE_KIND in _kinds(c.outputs))
    if not filters:
        raise ChainError(
            f"no receive filter in the graph: no block has an output of kind '{RESPONSE_KIND}' "
            "(e.g. filter.matched)"
        )
    if filter_name is None:
        if len(filters) > 1:
            raise ChainError(
                f"the graph has {len(filters)} receive filters ({', '.join(filters)}); "
                "choose one with --filter"
            )
        filter_name = filters[0]
    elif filter_name not in filters:
        raise ChainError(
            f"--filter {filter_name}: not a receive filter of the graph "
            f"(filters: {', '.join(filters)})"
        )
    upstream = nx.ancestors(graph.nx, filter_name)
    waveforms = sorted(
        n
        for n in upstream
        if PULSE_KIND in _kinds(graph.classes[n].outputs)
        and PULSE_KIND not in _kinds(graph.classes[n].inputs)
    )
    if not waveforms:
        raise ChainError(
            f"no waveform feeds the receive filter '{filter_name}': no block upstream of it "
            f"emits a '{PULSE_KIND}' without taking one (e.g. waveform.lfm)"
        )
    amplifiers = sorted(
        n
        for n in upstream
        if PULSE_KIND in _kinds(graph.classes[n].outputs)
        and PULSE_KIND in _kinds(graph.classes[n].inputs)
    )
    order = [n for n in graph.order() if n in upstream or n == filter_name]
    per_beam = [n for n in order if graph.classes[n].runs_per_chunk()]
    if per_beam:
        raise ChainError(
            f"the receive filter '{filter_name}' depends on beams through "
            f"{', '.join(repr(n) for n in per_beam)}: pasim waveform evaluates once-per-run "
            "chains only"
        )
    for name in amplifiers:
        pulse_inputs = [p for p in graph.classes[name].inputs.values() if p.type.kind == PULSE_KIND]
        if len(pulse_inputs) != 1 or len(graph.classes[name].inputs) != 1:
            raise ChainError(
                f"block '{name}' takes and emits a pulse but has inputs "
                f"{', '.join(graph.classes[name].inputs)}: it cannot be replaced by an ideal "
                "amplifier"
            )
    return Chain(filter_name, order, waveforms, amplifiers)


def run_chain(graph: Graph, chain: Chain, ideal: bool) -> dict[tuple[str, str], Any]:
    """Run the chain once (``ideal``: every amplifier a wire); values by (block, port)."""
    values: dict[tuple[str, str], Any] = {}
    for name in chain.order:
        cls = graph.classes[name]
        inputs = {e.dst_port: values[(e.src, e.src_port)] for e in graph.inputs_of(name)}
        if ideal and name in chain.amplifiers:
            drive = next(iter(inputs.values()))
            out = {p.name: drive for p in cls.outputs.values() if p.type.kind == PULSE_KIND}
        else:
            what = f"block '{name}' ({cls.type_name})"
            try:
                block = cls(name=name, **graph.params[name])
                resource = block.load()
                out = block.process(
                    inputs, Chunk(beams=np.arange(0), block_name=name, resource=resource)
                )
            except Exception as exc:
                raise ChainError(f"{what} failed: {type(exc).__name__}: {exc}") from None
            problems = [
                f"output port '{port}': {p}"
                for port, value in out.items()
                if port in cls.outputs
                for p in cls.outputs[port].type.check(value)
            ]
            if problems:
                raise ChainError(f"{what} returned a bad value: {'; '.join(problems)}")
        for port, value in out.items():
            values[(name, port)] = value
    return values


def _response(graph: Graph, chain: Chain, values: dict[tuple[str, str], Any]) -> xr.Dataset:
    port = next(
        p.name for p in graph.classes[chain.filter].outputs.values() if p.type.kind == RESPONSE_KIND
    )
    return values[(chain.filter, port)]


def figures(response: xr.Dataset, upsample: int = 8) -> dict[str, Any]:
    """Figures of merit of one range response (see compression.sidelobes)."""
    fs = float(response.attrs["sample_rate_hz"])
    dx = SPEED_OF_LIGHT / (2 * fs)
    y = response["voltage"].values
    s = response["transmitted"].values
    lobes = sidelobes(y, dx, upsample)
    offsets = response["offset_m"].values
    return {
        "psl_db": lobes["psl_db"],
        "psl_offset_m": float(offsets[0] + lobes["psl_index"] * dx),
        "isl_db": lobes["isl_db"],
        "range_resolution_m": lobes["resolution"],
        "mainlobe_peak_db": float(10 * np.log10(lobes["peak"])),
        "snr_loss_db": snr_loss_db(s, response["taps"].values),
        # Against the rated peak (envelope 1), or the pulse's own peak if it exceeds it.
        "power_efficiency": power_efficiency(s, max(1.0, float(np.max(np.abs(s))))),
        "blind_range_m": float(response.attrs["blind_range_m"]),
        "noise_bandwidth_hz": float(response.attrs["noise_bandwidth_hz"]),
        "sample_rate_hz": fs,
        "pulse_width_s": s.size / fs,
    }


@dataclass
class Analysis:
    """What ``pasim waveform`` reports and plots."""

    metrics: dict[str, Any]
    drive: xr.Dataset  # the pulse through an ideal transmitter
    actual: xr.Dataset  # range response through the graph's amplifiers
    ideal: xr.Dataset  # range response with ideal amplifiers


def analyse(graph: Graph, filter_name: str | None = None) -> Analysis:
    """Run the graph's fast-time chain with its amplifiers and with ideal ones."""
    chain = find_chain(graph, filter_name)
    actual = _response(graph, chain, run_chain(graph, chain, ideal=False))
    values = run_chain(graph, chain, ideal=True)
    ideal = _response(graph, chain, values)
    a, i = figures(actual), figures(ideal)
    drive = ideal["transmitted"].values
    metrics = {
        "graph": graph.spec.file,
        "filter": chain.filter,
        "waveforms": chain.waveforms,
        "amplifiers": chain.amplifiers,
        "psl_db": a["psl_db"],
        "psl_ideal_db": i["psl_db"],
        "isl_db": a["isl_db"],
        "isl_ideal_db": i["isl_db"],
        # The waveform's own efficiency (as the paper's 0.35 and 0.87): through a linear
        # transmitter, over a constant envelope at the same peak.
        "power_efficiency": power_efficiency(drive),
        # What the graph's amplifier radiates, over a constant envelope at the rated peak.
        "power_efficiency_radiated": a["power_efficiency"],
        "range_resolution_m": a["range_resolution_m"],
        "range_resolution_ideal_m": i["range_resolution_m"],
        "blind_range_m": a["blind_range_m"],
        "snr_loss_db": a["snr_loss_db"],
        "snr_loss_ideal_db": i["snr_loss_db"],
        "mainlobe_peak_db": a["mainlobe_peak_db"],
        "psl_offset_m": a["psl_offset_m"],
        "noise_bandwidth_hz": a["noise_bandwidth_hz"],
        "sample_rate_hz": a["sample_rate_hz"],
        "pulse_width_s": a["pulse_width_s"],
    }
    bandwidth = [
        float(v.attrs["bandwidth_hz"])
        for (b, _), v in values.items()
        if b in chain.waveforms and "bandwidth_hz" in v.attrs
    ]
    if bandwidth:
        metrics["bandwidth_hz"] = bandwidth[0]
    drive_ds = xr.Dataset(
        {"envelope": ("sample", drive)}, attrs={"sample_rate_hz": a["sample_rate_hz"]}
    )
    return Analysis(metrics, drive_ds, actual, ideal)
