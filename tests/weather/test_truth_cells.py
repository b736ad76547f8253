"""The truth cells prepared a block of radials at a time, as beams reach them, are the cells
prepared for the whole truth at once, to the bit (the independent computation: the same
per-cell formulas on the whole arrays, the path the ``combined`` level takes); preparing a few
radials prepares their blocks only; threads preparing at once get the same cells."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.receivers.filters import MatchedFilter
from pasim_blocks.waveforms.pulses import RectangularPulse
from pasim_blocks.weather.cells import FILL, TruthCells
from pasim_blocks.weather.fasttime import range_model

from pasim_graph import Chunk

LAM, PRT, PULSES = 0.107, 1e-3, 16


def scene(seed: int = 4) -> xr.Dataset:
    """720 radials of 60 gates: echo with holes, Level-II-like 0.5 m/s velocities and widths,
    a field missing (KDP is not a moment here) so its fill values are used."""
    gen = np.random.default_rng(seed)
    shape = (720, 60)
    dbz = gen.uniform(-10, 55, shape)
    dbz[gen.random(shape) < 0.3] = np.nan
    fields = {
        "DBZH": dbz,
        "VRADH": np.round(gen.uniform(-20, 20, shape) * 2) / 2,
        "WRADH": np.round(gen.uniform(0, 6, shape) * 2) / 2,
        "ZDR": gen.uniform(-1, 4, shape),
        "RHOHV": gen.uniform(0.9, 1.0, shape),
    }
    fields["VRADH"][gen.random(shape) < 0.1] = np.nan
    return xr.Dataset(
        {k: (("radial", "gate"), v.astype(np.float32)) for k, v in fields.items()},
        coords={
            "azimuth": ("radial", np.arange(720) * 0.5 + 0.25),
            "range": ("gate", 2e3 + 250.0 * np.arange(60)),
        },
        attrs={"gate_width_m": 250.0, "radial_width_deg": 0.5},
    )


@pytest.fixture(scope="module")
def pair():
    truth = scene()
    pulse = RectangularPulse(name="tx").process({}, Chunk(beams=np.arange(0)))["pulse"]
    response = MatchedFilter(name="mf").process(
        {"pulse": pulse, "reference": pulse}, Chunk(beams=np.arange(0))
    )["range_response"]
    ranges = range_model(response, 250.0, LAM, 20.0, floor_db=-80.0)
    lazy = TruthCells(truth, ranges, 1e-3, PRT, LAM, PULSES, "covariance", 8, np.float32)
    whole = TruthCells(truth, ranges, 1e-3, PRT, LAM, PULSES, "combined", 8, np.float32)
    return lazy, whole


def arrays(cells: TruthCells) -> dict[str, np.ndarray]:
    out = {
        name: getattr(cells, name)
        for name in ("echo", "s_h", "s_v", "rho", "r1_h", "r1_v", "cross", "u", "phase_dp")
    }
    out["lags"] = cells._lags
    out |= {f"field {k}": cells.field[k] for k in FILL}
    assert cells.factors is not None
    out["width codes"] = cells.factors.code
    return out


def test_cells_prepared_by_blocks_are_the_whole_truths_to_the_bit(pair):
    lazy, whole = pair
    rows = np.arange(3, 21)  # a beam's rows: two blocks of 16
    lazy.prepare(rows)
    assert lazy._done.sum() == 2
    untouched = slice(2 * TruthCells.BLOCK_ROWS, None)
    assert not lazy.s_h[untouched].any() and not lazy.r1_h[untouched].any()
    # The rest from four threads at once, in an order of their own.
    order = np.random.default_rng(1).permutation(720)
    threads = [threading.Thread(target=lazy.prepare, args=(order[k::4],)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert lazy._done.all()
    got, want = arrays(lazy), arrays(whole)
    for name in want:
        assert got[name].dtype == want[name].dtype, name
        assert got[name].tobytes() == want[name].tobytes(), f"{name} differs"
    assert lazy.echo.any() and (lazy.factors.code >= 0).sum() == lazy.echo.sum()
