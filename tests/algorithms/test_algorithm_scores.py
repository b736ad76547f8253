"""A study point's statistics with an algorithm product among its errors, on synthetic error
fields (no run: the reduction alone): the product is scored like a moment, and the moments'
entries are the same to the bit with or without it. The end-to-end study is
tests/algorithms/test_algorithm_study.py (slow)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from pasim_blocks.study import statistics as st


def errors(rng: np.random.Generator, product: bool, noise: float = 0.0) -> st.Errors:
    """Errors of one store on 40 beams x 60 gates: the six moments and, with ``product``,
    KDP_VULPIANI (deg/km, bias 0.2, std 0.5); ``noise`` shifts every field (another level)."""
    shape = (40, 60)
    fields = {n: rng.normal(0.1, 1.0, shape) + noise for n in st.FIELDS}
    fields["DBZH"][:, :5] = np.nan  # some gates unscored
    reqs = {n: (1.0, 1.0) for n in st.FIELDS}
    units = {n: "" for n in st.FIELDS}
    products = []
    if product:
        fields["KDP_VULPIANI"] = rng.normal(0.2, 0.5, shape) + noise
        reqs["KDP_VULPIANI"], units["KDP_VULPIANI"] = (0.1, 0.3), "degrees km-1"
        products = ["KDP_VULPIANI"]
    return st.Errors(
        np.arange(40.0), 250.0 * np.arange(60), fields, {"PHIDP": 360.0}, reqs, units, products
    )


def score(product: bool) -> tuple[dict, st.Errors]:
    """``_score_point`` of one system whose estimate, own expected level and references are
    the synthetic stores (the same draws with or without the product)."""
    kinds = {
        k: errors(np.random.default_rng(i), product, noise=0.05 * i)
        for i, k in enumerate(("estimate", "expected", "sidelobe_free", "short_pulse"))
    }
    study = SimpleNamespace(seeds=[0], reference="sys")

    def find(system, case, point, kind, seed):
        return kind

    out = st._score_point(study, "sys", "c", "-", find, kinds.get, {}, {"sys/c/-": 1.0}, [])
    return out, kinds["estimate"]


def test_a_product_is_scored_as_a_moment_and_leaves_the_moments_alone():
    """The product's std, bias and count against numpy on its finite errors, its noise
    interval around its std, its requirement and units from the store, its place after the
    moments; every moment's entry identical (as JSON) to the same point without the product."""
    with_product, est = score(True)
    bare, _ = score(False)
    assert list(with_product) == [*st.FIELDS, "KDP_VULPIANI"]
    got = with_product["KDP_VULPIANI"]
    x = est.fields["KDP_VULPIANI"]
    assert got["count"] == x.size
    assert got["std"] == pytest.approx(x.std(ddof=1), rel=1e-12)
    assert got["bias"] == pytest.approx(x.mean(), rel=1e-12)
    lo, hi = got["noise_ci"]["std"]
    assert lo < got["std"] < hi
    assert (got["requirement_bias"], got["requirement_std"], got["units"]) == (
        0.1,
        0.3,
        "degrees km-1",
    )
    assert got["product"].startswith("algorithm")
    assert got["own_expected"]["std"] > 0 and got["budget"]["count"] == x.size
    assert "product" not in with_product["DBZH"]
    for name in st.FIELDS:
        assert json.dumps(with_product[name], sort_keys=True) == json.dumps(
            bare[name], sort_keys=True
        ), name


def test_the_reports_product_table_holds_the_products_numbers():
    """The report's product rows (blocks/study/report.py) are the products of the scores, with
    their std and bias as scores.json has them; the moments' rows hold no product."""
    from pasim_blocks.study.report import format_number, product_names, summary_rows

    point, _ = score(True)
    scores = {"sys": {"c": {"-": point}}}
    names = product_names(scores, ["sys"], "c")
    assert names == ["KDP_VULPIANI"]
    (row,) = summary_rows(scores, ["sys"], "c", names)
    assert (row["field"], row["req_bias"], row["req_std"]) == ("KDP_VULPIANI", 0.1, 0.3)
    (cell,) = row["cells"]
    assert (cell["std"], cell["bias"]) == (
        format_number(point["KDP_VULPIANI"]["std"]),
        format_number(point["KDP_VULPIANI"]["bias"]),
    )
    assert [r["field"] for r in summary_rows(scores, ["sys"], "c")] == list(st.FIELDS)
