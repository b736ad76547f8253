"""The must-show of docs/algorithms.md: region-based dealiasing on the bundled storm at C band,
PRT 2 ms (graphs/dealias_cband.yaml), the fraction of scored gates within 2 m/s of the truth's
velocity before and after, reproduced from a fresh run."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from ..conftest import GRAPHS, ROOT, pasim_out


def row_in_the_docs() -> tuple[int, int, float, float]:
    """Gates, folded gates, and the fractions before and after, of the PRT 2 ms row of
    docs/algorithms.md's table."""
    text = (ROOT / "docs" / "algorithms.md").read_text()
    row = next(line for line in text.splitlines() if line.startswith("| `dealias_cband.yaml`"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    return int(cells[2]), int(cells[3]), float(cells[4]), float(cells[5])


@pytest.mark.slow
def test_region_dealiasing_on_the_folded_storm(capsys, tmp_path):
    """Independent of the block: the fractions are computed here from the stored estimate,
    dealiased velocity and truth, on the scorer's scored gates; they are the docs' numbers,
    and dealiasing raises the fraction."""
    out = tmp_path / "dealias.zarr"
    code, _, err = pasim_out(capsys, "run", str(GRAPHS / "dealias_cband.yaml"), "--out", str(out))
    assert code == 0, err
    s = xr.open_datatree(out, engine="zarr")["sweep_0"].to_dataset()
    v, t = s["VRADH"].values, s["truth_VRADH"].values
    d = s["VRADH_DEALIASED_REGION"].values
    gates = s["scored"].values.astype(bool) & np.isfinite(v) & np.isfinite(t)
    assert np.isfinite(d[gates]).all()
    before = float(np.mean(np.abs(v[gates] - t[gates]) <= 2.0))
    after = float(np.mean(np.abs(d[gates] - t[gates]) <= 2.0))
    folded = int(np.sum(np.abs(t[gates]) > float(s["nyquist_velocity"].values[0])))
    measured = (int(gates.sum()), folded, round(before, 4), round(after, 4))
    assert measured == row_in_the_docs()
    assert before < after
