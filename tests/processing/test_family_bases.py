"""The family bases: the moment processors derive from MomentProcessor and the scans from Scan
(PPI, RHI and volume from DwellScan), so what a family shares is declared once, read from the
classes alone by the registry and the validator (nothing built); the staggered mean PRT has
one definition, which the scans' dwell times and the scores' time on target both use."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.processing.moment_processor import MomentProcessor
from pasim_blocks.processing.output import Censoring
from pasim_blocks.scans.scan import DwellScan, Scan
from pasim_blocks.timing import STAGGERS

from pasim_graph import Block, Chunk, GraphError, registry
from pasim_graph.graph import validate
from pasim_graph.graphfile import parse
from pasim_graph.scores import mean_prt, time_on_target

from ..conftest import GRAPHS

PROCESSORS = ("processor.pulse_pair", "processor.spectral", "processor.staggered", "processor.sz2")
DWELL_SCANS = ("scan.ppi", "scan.rhi", "scan.volume")


def declared(decls: dict) -> dict:
    """Declarations as comparable data (the frozen dataclasses' fields)."""
    return {k: dict(vars(v)) for k, v in decls.items()}


def own(cls: type, base: type) -> dict:
    """What ``cls`` declares beyond ``base``: ports and parameters with their own values."""
    return {
        kind: {
            k: v
            for k, v in getattr(cls, kind).items()
            if k not in getattr(base, kind) or v != getattr(base, kind)[k]
        }
        for kind in ("inputs", "outputs", "params")
    }


@pytest.mark.parametrize("name", PROCESSORS)
def test_each_processor_shares_the_bases_inputs_and_censoring(name):
    cls = registry.get(name)
    assert cls is not None and issubclass(cls, MomentProcessor)
    shared = ("iq", "noise_power", "calibration", "beams")
    assert list(cls.inputs)[:4] == list(shared)
    assert declared({k: cls.inputs[k] for k in shared}) == declared(MomentProcessor.inputs)
    # The censoring thresholds come from the base, in its order, unchanged; so does the
    # motion compensation (docs/platform.md).
    censoring = [k for k in MomentProcessor.params if k in vars(Censoring)]
    assert censoring == [k for k in vars(Censoring) if not k.startswith("_")]
    assert list(MomentProcessor.params) == [*censoring, "motion_compensation"]
    base = MomentProcessor.params
    assert declared({k: cls.params[k] for k in base}) == declared(base)
    assert set(cls.outputs) == {"moments"} and "process" in vars(cls)
    # The interface is read from the class alone, the base's declarations included.
    interface = cls.interface()
    assert [p["name"] for p in interface["inputs"]][:4] == list(shared)


def test_processors_declare_only_what_is_their_own():
    """Beyond the base: pulse-pair its optional expected correlations, spectral and SZ-2 the
    fields they write and their own parameters, staggered nothing."""
    found = {name: own(registry.get(name), MomentProcessor) for name in PROCESSORS}
    assert set(found["processor.pulse_pair"]["inputs"]) == {"echo_correlations"}
    assert not found["processor.staggered"]["inputs"] and not found["processor.staggered"]["params"]
    assert "CCORH" in found["processor.spectral"]["outputs"]["moments"].fields
    assert "window" in found["processor.spectral"]["params"]
    assert "max_power_ratio_db" in found["processor.sz2"]["params"]
    for name in PROCESSORS:
        assert not any(k in MomentProcessor.inputs for k in found[name]["inputs"]), name


@pytest.mark.parametrize("name", PROCESSORS)
def test_a_transmission_a_processor_does_not_handle_is_refused_naming_it(name):
    cls = registry.get(name)
    cal = xr.Dataset(attrs={"wavelength_m": 0.1, "transmission": "xyz"})
    beams = xr.Dataset({"prt": ("beam", [1e-3])})
    inputs = {"iq": np.zeros((1, 1, 8, 2)), "noise_power": np.ones((1, 1, 2))}
    block = cls(name="p")
    with pytest.raises(ValueError, match=rf"{name} handles transmission shv.*'xyz'"):
        block.dwell({**inputs, "calibration": cal, "beams": beams}, Chunk(beams=np.arange(1)))


def test_a_plugin_processor_on_the_base_declares_nothing_shared():
    """A processor written on the base alone has the family's ports and thresholds, and its
    process is the prologue, an estimator and the shared last step."""

    class Power(MomentProcessor):
        """Power only."""

        def process(self, inputs, chunk):
            d = self.dwell(inputs, chunk)
            est = {"S_H": np.mean(np.abs(d.iq[..., 0]) ** 2, axis=-1) - d.noise[..., 0]}
            return self.moments_output(est, d.noise[..., 0], d, chunk, 0.1 / (4 * d.prt_s))

    assert list(Power.inputs) == list(MomentProcessor.inputs)
    assert list(Power.params) == list(MomentProcessor.params)
    gates = np.array([100.0, 200.0])
    cal = xr.Dataset(
        {"radar_constant_db": (("beam", "polarization"), [[0.0, 0.0]])},
        coords={"range": ("range", gates)},
        attrs={"wavelength_m": 0.1, "blind_range_m": 0.0, "calibration": "test"},
    )
    iq = np.full((1, 2, 4, 2), 2.0 + 0j)
    inputs = {
        "iq": iq,
        "noise_power": np.ones((1, 2, 2)),
        "calibration": cal,
        "beams": xr.Dataset({"prt": ("beam", [1e-3])}),
    }
    ds = Power(name="p").process(inputs, Chunk(beams=np.arange(1)))["moments"]
    # 4 W less 1 W of noise at 100 m and 200 m, the radar constant 0 dB.
    expected = 10 * np.log10(3.0) + 20 * np.log10(gates)
    np.testing.assert_allclose(ds["DBZH"].values[0], expected, rtol=1e-6)
    assert ds.attrs["transmission"] == "shv" and ds.attrs["phidp_period_deg"] == 360.0


@pytest.mark.parametrize("name", (*DWELL_SCANS, "scan.schedule"))
def test_each_scan_shares_the_bases_declarations(name):
    cls = registry.get(name)
    assert cls is not None and issubclass(cls, Scan)
    assert cls.role == "scan" and cls.beam_source
    assert declared(cls.inputs) == declared(Scan.inputs)
    assert declared(cls.outputs) == declared(Scan.outputs)
    if name in DWELL_SCANS:
        assert issubclass(cls, DwellScan)
        shared = DwellScan.params
        assert declared({k: cls.params[k] for k in shared}) == declared(shared)
    else:
        assert not set(DwellScan.params) & set(cls.params)


def test_given_reads_the_graphs_value_else_the_default():
    ppi = registry.get("scan.ppi")
    assert ppi is not None and issubclass(ppi, Scan)
    assert ppi.given({"pulses": 32}, "pulses") == 32
    assert ppi.given({}, "pulses") == DwellScan.params["pulses"].default == 64


def test_the_validator_checks_inherited_parameters_and_the_scans_config():
    """A bound of a parameter the base declares, and a scan's own check reading the graph's
    values through the base's helper, are both named at validation."""
    spec = parse((GRAPHS / "uniform_staggered.yaml").read_text(), "uniform_staggered.yaml")
    with pytest.raises(GraphError) as info:
        validate(spec, {"scan.pulses": 1, "scan.azimuth_stop_deg": 0.0})
    text = str(info.value)
    assert "parameter 'pulses'" in text
    assert "parameter 'azimuth_stop_deg'" in text and "same azimuth" in text
    rhi = parse((GRAPHS / "generic_rhi.yaml").read_text(), "generic_rhi.yaml")
    with pytest.raises(GraphError, match=r"elevation_stop_deg 0\.2 deg is below it"):
        validate(rhi, {"scan.elevation_stop_deg": 0.2})


@pytest.mark.parametrize("stagger", sorted(STAGGERS))
def test_one_mean_prt_for_the_scans_and_the_scores(stagger):
    """The PPI's dwell time (its beams' time steps and the sweep's end), the volume's sweep
    start times and the scores' time on target use the same mean PRT, to the bit."""
    ratio = float(STAGGERS[stagger])
    t1 = 1e-3
    mean = mean_prt(t1, ratio)
    assert mean == t1 * (1.0 + 1.0 / ratio) / 2.0
    ppi_cls = registry.get("scan.ppi")
    assert ppi_cls is not None
    ppi: Block = ppi_cls(name="scan", prt_s=t1, pulses=10, stagger=stagger)
    beams = ppi.process({}, Chunk(beams=np.arange(ppi.beam_count())))["beams"]
    n = ppi.beam_count()
    start = beams["time"].values[0]
    dwell_ns = (np.arange(n) * (10 * mean) * 1e9).astype("timedelta64[ns]")
    np.testing.assert_array_equal(beams["time"].values, start + dwell_ns)
    assert time_on_target(beams) == float(np.sum(np.full(n, 10.0) * mean))
    np.testing.assert_array_equal(mean_prt(np.full(3, t1), np.full(3, ratio)), np.full(3, mean))
    volume = registry.get("scan.volume")
    assert volume is not None
    sweeps = volume.scan_sweeps(
        {
            "preset": "",
            "cuts": "0.5 0.001 10; 1.5 0.001 10",
            "stagger": stagger,
            "azimuth_start_deg": 0.0,
            "azimuth_stop_deg": 20.0,
            "beam_spacing_deg": 1.0,
        }
    )
    assert sweeps[1]["time_offset_s"] == 20 * 10 * mean
