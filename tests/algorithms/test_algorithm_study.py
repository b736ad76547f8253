"""A study whose system carries algorithm blocks (``algorithm.dealias``, ``algorithm.kdp``,
``algorithm.rain_rate``) scores their products beside the moments, in ``scores.json``,
``scores.csv`` and the HTML report, and leaves the moments' numbers as they were.

One study of one system on 3 beams of the bundled scene (4 runs, about 45 s on 2 busy
cores): slow-marked.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pasim_blocks.study import statistics as st
from pasim_blocks.study.model import read_study
from pasim_blocks.study.plan import plan_runs
from pasim_blocks.study.report import REPORT

from pasim_graph.cli import main

pytestmark = pytest.mark.slow

FIX = Path(__file__).parents[1] / "fixtures" / "algorithms"
STUDY = FIX / "algo_study.yaml"
PRODUCTS = ("VRADH_DEALIASED_REGION", "KDP_VULPIANI", "RATE_Z", "RATE_KDP")


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("algo-study") / "out"
    assert main(["study", str(STUDY), "--out", str(out)]) == 0
    return out


def scores(out: Path) -> dict:
    return json.loads((out / "scores.json").read_text())


def test_products_are_scored_like_the_moments(study):
    """Each product's std, bias and count against an independent numpy reduction of the
    store's ``error_<product>`` (the product minus the same algorithm on the truth), with
    both intervals around the statistic, as for a moment."""
    point = scores(study)["algo"]["convective"]["-"]
    store = study / "runs" / "algo" / "convective" / "-" / "estimate-seed0.zarr"
    sweep = xr.open_datatree(store, engine="zarr")["sweep_0"].to_dataset()
    for name in PRODUCTS:
        got = point[name]
        x = np.asarray(sweep[f"error_{name}"].values, np.float64)
        x = x[np.isfinite(x)]
        assert x.size > 100, name
        assert got["product"].startswith("algorithm")
        assert got["count"] == x.size
        assert got["std"] == pytest.approx(x.std(ddof=1), rel=1e-9)
        assert got["bias"] == pytest.approx(x.mean(), abs=1e-9)
        lo, hi = got["noise_ci"]["std"]
        assert lo <= got["std"] <= hi, name
        # The scene interval as the moments': 3 beams are too few blocks for the bootstrap.
        assert (got["scene_ci"]["std"][0] is None) == (point["DBZH"]["scene_ci"]["std"][0] is None)
        assert got["own_expected"] is not None and got["common"] is not None
        assert (got["requirement_bias"], got["requirement_std"]) == (
            sweep[f"error_{name}"].attrs["requirement_bias"],
            sweep[f"error_{name}"].attrs["requirement_std"],
        )
    # The moments come first, then the products; rankings stay the moments'.
    assert list(point)[:6] == list(st.FIELDS)
    ranked = scores(study)["_study"]["rankings"]["convective"]
    assert not set(ranked) & set(PRODUCTS)


def test_the_moments_are_scored_as_without_products(study):
    """Scored again with the products stripped from every store's errors (what the study
    read before products were scored), the six moments' entries are identical to the bit."""
    spec = read_study(STUDY)
    runs, problems = plan_runs(spec)
    assert not problems
    beamwidths = scores(study)["_study"]["beamwidths_deg"]
    with_products = st.score_study(spec, runs, study, beamwidths)
    read = st.read_errors

    def without(path):
        e = read(path)
        for name in e.products:
            del e.fields[name]
        e.products = []
        return e

    st.read_errors = without
    try:
        bare = st.score_study(spec, runs, study, beamwidths)
    finally:
        st.read_errors = read
    a, b = with_products["algo"]["convective"]["-"], bare["algo"]["convective"]["-"]
    assert set(b) == set(st.FIELDS)
    for name in st.FIELDS:
        assert json.dumps(a[name], sort_keys=True) == json.dumps(b[name], sort_keys=True), name


def test_the_csv_and_the_report_list_the_products(study):
    point = scores(study)["algo"]["convective"]["-"]
    with open(study / "scores.csv") as f:
        rows = [
            r
            for r in csv.DictReader(f)
            if r["field"] == "KDP_VULPIANI" and r["gates"] == "own" and r["against"] == "raw"
        ]
    got = {r["quantity"]: r["value"] for r in rows}
    assert float(got["std"]) == pytest.approx(point["KDP_VULPIANI"]["std"], rel=1e-12)
    assert float(got["bias"]) == pytest.approx(point["KDP_VULPIANI"]["bias"], rel=1e-12)
    html = (study / REPORT).read_text()
    table = html.split('id="products-table-convective"', 1)[1].split("</table>", 1)[0]
    for name in PRODUCTS:
        assert f"<th>{name} " in table
        assert f"std {point[name]['std']:.3g}" in table
    # The moments' summary table holds no product.
    summary = html.split('id="summary-table-convective"', 1)[1].split("</table>", 1)[0]
    assert "KDP_VULPIANI" not in summary
