"""The expected level is a declared fact the engine hands to blocks (``Chunk.expected``), not a
pulse axis of length 0 that blocks read as a signal: the executors set it once per run from
the classes' fidelity declarations and the graph's values, and a block handed a cube whose
pulse axis contradicts it refuses, naming itself."""

from __future__ import annotations

import pickle
from typing import Any

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.processing.pulse_pair import PulsePairProcessor
from pasim_blocks.processing.spectral import SpectralProcessor
from pasim_blocks.processing.sz2 import SZ2Processor
from pasim_blocks.receivers.adc import ADC
from pasim_blocks.receivers.phase_noise import PhaseNoise
from pasim_blocks.receivers.receiver import Receiver
from pasim_blocks.signals import CORRELATION_PRODUCTS
from pasim_blocks.transmitters.jitter import TransmitterJitter
from pasim_blocks.weather.clutter import GroundClutter

from pasim_graph import Block, Chunk, Param, load
from pasim_graph.executor import LocalExecutor, RunOptions

from ..conftest import GRAPHS
from .test_fidelity_declaration import Leveled

UNIFORM = GRAPHS / "uniform_ideal.yaml"
#: Two beams of eight pulses of the uniform scene.
SMALL = {"scan.azimuth_stop_deg": 2.0, "scan.pulses": 8}


class Undeclared(Block):
    method = Param("expected", type="str", choices=("a", "expected"), doc="no declaration")


def test_a_chunk_built_without_the_level_draws_pulses() -> None:
    assert Chunk(beams=np.arange(2)).expected is False


def test_the_graph_reads_the_declaration_not_a_name(monkeypatch: pytest.MonkeyPatch) -> None:
    assert load(UNIFORM, {"weather.method": "expected"}).at_expected_level()
    for method in ("combined", "covariance", "monte_carlo"):
        assert not load(UNIFORM, {"weather.method": method}).at_expected_level()
    graph = load(UNIFORM)
    # A parameter named 'method' at 'expected' on a block that declares no fidelity is not
    # the level; a declared parameter of another name at its declared level is.
    monkeypatch.setitem(graph.classes, "ppp", Undeclared)
    monkeypatch.setitem(graph.params, "ppp", {})
    assert not graph.at_expected_level()
    monkeypatch.setitem(graph.classes, "ppp", Leveled)
    assert not graph.at_expected_level()
    monkeypatch.setitem(graph.params, "ppp", {"level": "noise_free"})
    assert graph.at_expected_level()


@pytest.mark.parametrize("method", ["expected", "covariance"])
def test_the_executor_hands_every_block_the_level(
    method: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every Chunk the local executor builds (once-per-run blocks and per-chunk ones) says
    whether the run is at the expected level; the cube's pulse axis agrees with it."""
    graph = load(UNIFORM, {**SMALL, "weather.method": method})
    executor = LocalExecutor(graph, RunOptions(chunk_beams=1))
    seen: dict[str, set[bool]] = {}
    pulses: set[int] = set()
    for block in executor.plan.blocks.values():

        def spy(inputs: dict[str, Any], chunk: Chunk, _process=block.process) -> dict:
            seen.setdefault(chunk.block_name, set()).add(chunk.expected)
            if "iq" in inputs:
                pulses.add(inputs["iq"].shape[2])
            return _process(inputs, chunk)

        monkeypatch.setattr(block, "process", spy)
    executor.run()
    assert {"scene", "scan", "weather", "receiver", "ppp"} <= set(seen)
    assert all(levels == {method == "expected"} for levels in seen.values()), seen
    assert pulses == ({0} if method == "expected" else {8})


@pytest.mark.parametrize("method", ["expected", "covariance"])
def test_the_dask_path_carries_the_level(method: str) -> None:
    """What a Dask worker is sent (each sweep's executor trimmed for the chunks, pickled)
    carries the plan's level, from which it builds its chunks."""
    from pasim_graph.dask_executor import DaskExecutor

    graph = load(UNIFORM, {**SMALL, "weather.method": method})
    dask = DaskExecutor(graph, RunOptions(chunk_beams=1))
    for sweep in dask.sweeps:
        sent = pickle.loads(pickle.dumps(sweep.for_chunks()))
        assert sent.plan.expected is (method == "expected")


# ------------------------------------------------- a cube that contradicts the declared level


def _cube(pulses: int) -> np.ndarray:
    return np.ones((2, 4, pulses, 2), np.complex64)


def _processor_inputs(pulses: int) -> dict[str, Any]:
    cal = xr.Dataset(
        {"radar_constant_db": (("beam", "polarization"), np.full((2, 2), -60.0))},
        coords={"range": ("range", 100.0 + 250.0 * np.arange(4))},
        attrs={"wavelength_m": 0.107, "blind_range_m": 0.0, "calibration": "test"},
    )
    return {
        "iq": _cube(pulses),
        "noise_power": np.ones((2, 4, 2)),
        "calibration": cal,
        "beams": xr.Dataset({"prt": ("beam", [1e-3, 1e-3])}),
        "echo_correlations": np.ones((2, 4, len(CORRELATION_PRODUCTS)), np.complex128),
    }


BLOCKS = [
    pytest.param(PulsePairProcessor(name="ppp"), "iq", id="processor.pulse_pair"),
    pytest.param(SpectralProcessor(name="spectral"), "iq", id="processor.spectral"),
    pytest.param(Receiver(name="rx"), "iq_in", id="receiver.basic"),
    pytest.param(ADC(name="adc"), "iq_in", id="receiver.adc"),
    pytest.param(PhaseNoise(name="pn"), "iq_in", id="receiver.phase_noise"),
    pytest.param(TransmitterJitter(name="jitter"), "iq_in", id="transmitter.jitter"),
    pytest.param(GroundClutter(name="clutter"), "iq_in", id="weather.clutter"),
]


def _inputs(port: str, pulses: int) -> dict[str, Any]:
    inputs = _processor_inputs(pulses)
    inputs[port] = inputs.pop("iq") if port != "iq" else inputs["iq"]
    inputs["echo_correlations_in"] = inputs["echo_correlations"]
    return {**inputs, "truth": None, "pattern": None}


@pytest.mark.parametrize(("block", "port"), BLOCKS)
def test_no_pulses_without_the_expected_level_is_refused(block: Block, port: str) -> None:
    with pytest.raises(ValueError, match=f"block '{block.name}'.*no pulses.*not at the expected"):
        block.process(_inputs(port, 0), Chunk(beams=np.arange(2), expected=False))


@pytest.mark.parametrize(("block", "port"), BLOCKS)
def test_pulses_at_the_expected_level_are_refused(block: Block, port: str) -> None:
    with pytest.raises(ValueError, match=f"block '{block.name}'.*expected level.*8 pulses"):
        block.process(_inputs(port, 8), Chunk(beams=np.arange(2), expected=True))


def test_the_pulse_pair_processor_decides_on_the_level() -> None:
    """At the expected level it estimates from the expected correlations; unconnected, it
    refuses naming itself, the weather channel's level and what to connect."""
    inputs = _processor_inputs(0)
    inputs["echo_correlations"] = inputs["echo_correlations"] * 100.0  # 20 dB over the noise
    chunk = Chunk(beams=np.arange(2), expected=True)
    ds = PulsePairProcessor(name="ppp").process(inputs, chunk)["moments"]
    assert np.isfinite(ds["DBZH"].values).all()
    del inputs["echo_correlations"]
    with pytest.raises(ValueError, match=r"block 'ppp'.*'expected'.*echo_correlations"):
        PulsePairProcessor(name="ppp").process(inputs, chunk)


@pytest.mark.parametrize("cls", [SpectralProcessor, SZ2Processor])
def test_a_processor_that_needs_pulses_refuses_the_expected_level(cls: type[Block]) -> None:
    with pytest.raises(ValueError, match=r"block 'p'.*method 'expected' draws none"):
        cls(name="p").process(_processor_inputs(0), Chunk(beams=np.arange(2), expected=True))
