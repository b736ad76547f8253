"""What a store holds is what was computed: the saved I/Q cubes and every variable's dtype.

What each test compares against:

* the stored cube: the processor itself. The graph is run again with the receiver's output
  replaced by the cube read back from the store; the pulse-pair processor must then give the
  stored moments exactly (the same float32 operations on the same numbers). A cube stored
  without its Q channel, or cast, gives other moments.
* the stored power: theory. The mean of |I/Q|^2 over pulses is an unbiased estimate of the
  expected echo power plus the noise power, noise * (1 + 10^(SNRH / 10)) with the stored
  expected SNR. Averaged over every gate of the run (4 beams x 1832 gates x 16 pulses; gates
  250 m apart correlate 0.22 in voltage, pulses by the spectrum width) the ratio of the two
  has a standard error well under 1 %: the check allows 5 %. The real part alone gives 0.5.
* dtypes: each stored variable against the dtype its block computed (the first beam run in
  memory).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from pasim_graph.executor import LocalExecutor, RunOptions, merge_products
from pasim_graph.graph import load

from ..conftest import GRAPHS, pasim_in_process

SECTOR = {"scan.azimuth_start_deg": 282.0, "scan.azimuth_stop_deg": 286.0, "scan.pulses": 16}
SEED = 7


@pytest.fixture(scope="module")
def iq_store(tmp_path_factory):
    out = tmp_path_factory.mktemp("iq") / "iq.zarr"
    args = ["run", str(GRAPHS / "generic_radar.yaml"), "--sector", "282:286"]
    args += ["--set", "scan.pulses=16", "--seed", str(SEED), "--save-iq", "--out", str(out)]
    res = pasim_in_process(*args)
    assert res.returncode == 0, res.stderr
    return xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()


def test_stored_iq_is_complex_with_the_echo_power(iq_store):
    for name in ("IQ_H", "IQ_V"):
        cube = iq_store[name]
        assert cube.dtype == np.complex64, f"{name} stored as {cube.dtype}"
        assert cube.dims == ("azimuth", "range", "pulse")
        q = np.imag(cube.values)
        assert np.abs(q).max() > 0, f"{name} has no Q channel"
    import scipy.constants

    graph = load(GRAPHS / "generic_radar.yaml", SECTOR)
    # k T0 F B, B = 1 / tau for the rectangular pulse and its matched filter
    bandwidth = 1 / graph.value("tx", "width_s")
    noise = scipy.constants.k * 290.0 * 10 ** (graph.value("receiver", "noise_figure_db") / 10)
    noise *= bandwidth
    measured = (np.abs(iq_store["IQ_H"].values) ** 2).mean(axis=-1)
    expected = noise * (1 + 10 ** (iq_store["SNRH"].values / 10))
    ok = np.isfinite(expected)
    ratio = measured[ok].mean() / expected[ok].mean()
    assert abs(ratio - 1) < 0.05, f"stored power / (echo + noise) = {ratio:.4f}"


def test_moments_recomputed_from_the_stored_iq_equal_the_stored_moments(iq_store, monkeypatch):
    graph = load(GRAPHS / "generic_radar.yaml", SECTOR)
    receiver = next(n for n in graph.classes if graph.classes[n].type_name == "receiver.basic")
    cls = graph.classes[receiver]
    stored = np.stack([iq_store["IQ_H"].values, iq_store["IQ_V"].values], axis=-1)
    original = cls.process
    replaced = []

    def from_store(self, inputs, chunk):
        out = original(self, inputs, chunk)
        out["iq"] = stored[chunk.beams]
        replaced.append(len(chunk.beams))
        return out

    monkeypatch.setattr(cls, "process", from_store)
    options = RunOptions(seed=SEED + 1, chunk_beams=4)  # another seed: noise must not matter
    ex = LocalExecutor(graph, options)
    ex.load()
    static = ex.run_static()
    sweep = merge_products(ex.run_chunk(static, np.arange(4)))
    assert replaced == [4]
    for name in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        again, kept = sweep[name].values, iq_store[name].values
        assert again.shape == kept.shape
        np.testing.assert_array_equal(again, kept, err_msg=name)


def test_every_stored_variable_keeps_its_computed_dtype(iq_store):
    graph = load(GRAPHS / "generic_radar.yaml", SECTOR)
    ex = LocalExecutor(graph, RunOptions(seed=SEED, save_iq=True))
    ex.load()
    static = ex.run_static()
    first = merge_products(ex.run_chunk(static, np.arange(1)))
    checked = 0
    for name, var in first.data_vars.items():
        if "beam" in var.dims and name in iq_store:
            assert iq_store[name].dtype == var.dtype, f"{name}: {iq_store[name].dtype}"
            checked += 1
    assert checked >= 20
