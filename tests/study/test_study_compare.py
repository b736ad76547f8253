"""``pasim score STORE --against REF.zarr``, ``pasim score STORE --by azimuth[:BIN]`` and
``pasim compare A.zarr B.zarr ...`` on the tiny study's stores, against numpy reductions of
the stores read directly with xarray."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import zarr

from pasim_graph.cli import main

STUDY = Path(__file__).parents[1] / "fixtures" / "study" / "tiny_study.yaml"
FIELDS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")


@pytest.fixture(scope="module")
def runs(tiny_study) -> Path:
    return tiny_study / "runs"


def sweep(path: Path) -> xr.Dataset:
    return xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()


def store(runs: Path, system: str, kind: str) -> Path:
    seed = "seed0" if kind in ("estimate", "expected") else "ref"
    return runs / system / "convective" / "-" / f"{kind}-{seed}.zarr"


def circle(d: np.ndarray, period: float | None) -> np.ndarray:
    return d if period is None else d - period * np.round(d / period)


def printed_json(capsys, argv: list[str]):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_score_against_another_store(runs, capsys):
    est, ref = store(runs, "narrow", "estimate"), store(runs, "narrow", "sidelobe_free")
    got = printed_json(capsys, ["score", str(est), "--against", str(ref), "--json"])
    a, b = sweep(est), sweep(ref)
    for name in FIELDS:
        period = a[f"error_{name}"].attrs.get("period")
        d = circle(
            a[name].values.astype(float) - b[name].values.astype(float),
            float(period) if period else None,
        )
        d = d[np.isfinite(a[f"error_{name}"].values) & np.isfinite(d)]
        g = got[name]
        assert g["count"] == d.size
        assert g["bias"] == pytest.approx(d.mean(), abs=1e-6)
        assert g["std"] == pytest.approx(d.std(ddof=1), rel=1e-5)
        mad = np.median(np.abs(d - np.median(d)))
        assert g["robust_std"] == pytest.approx(1.4826 * mad, rel=1e-5)
        assert np.all(np.abs(d) <= (float(period) / 2 if period else np.inf))
    # The text table says the same.
    assert main(["score", str(est), "--against", str(ref)]) == 0
    text = capsys.readouterr().out
    assert f"{got['DBZH']['count']:,}" in text and "robust" in text


def test_score_by_azimuth_bins(runs, capsys):
    est = store(runs, "wide", "estimate")
    got = printed_json(capsys, ["score", str(est), "--by", "azimuth:2", "--json"])
    s = sweep(est)
    az = s["azimuth"].values
    e = s["error_ZDR"].values.astype(float)
    keys = np.floor((az - az[0]) / 2.0).astype(int)
    assert [r["beams"] for r in got] == [int((keys == k).sum()) for k in np.unique(keys)]
    for row, k in zip(got, np.unique(keys), strict=True):
        x = e[keys == k]
        x = x[np.isfinite(x)]
        assert row["ZDR"]["count"] == x.size
        assert row["ZDR"]["std"] == pytest.approx(x.std(ddof=1), rel=1e-5)
        assert row["ZDR"]["bias"] == pytest.approx(x.mean(), abs=1e-6)
    # Each beam, and against a reference: one row per beam, the profile's counts add up.
    ref = store(runs, "wide", "expected")
    beams = printed_json(
        capsys, ["score", str(est), "--by", "azimuth", "--against", str(ref), "--json"]
    )
    assert len(beams) == az.size
    whole = printed_json(capsys, ["score", str(est), "--against", str(ref), "--json"])
    assert sum(r["DBZH"]["count"] for r in beams) == whole["DBZH"]["count"]


def test_compare_on_common_gates(runs, capsys):
    a, b = store(runs, "narrow", "estimate"), store(runs, "wide", "estimate")
    got = printed_json(capsys, ["compare", str(a), str(b), "--json"])
    assert got["stores"] == ["narrow", "wide"]
    ea, eb = sweep(a), sweep(b)
    for name in FIELDS:
        x, y = ea[f"error_{name}"].values.astype(float), eb[f"error_{name}"].values.astype(float)
        both = np.isfinite(x) & np.isfinite(y)
        r = got["fields"][name]
        assert r["common_count"] == int(both.sum())
        for s, e in zip(r["stores"], (x, y), strict=True):
            assert s["count"] == int(both.sum())
            assert s["own_count"] == int(np.isfinite(e).sum())
            assert s["std"] == pytest.approx(e[both].std(ddof=1), rel=1e-5)
            mad = np.median(np.abs(e[both] - np.median(e[both])))
            assert s["robust_std"] == pytest.approx(1.4826 * mad, rel=1e-5)
    assert main(["compare", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "narrow" in out.splitlines()[0] and "DBZH own gates" in out


def test_different_grids_are_refused_by_name(runs, tmp_path, capsys):
    a = store(runs, "narrow", "estimate")
    shifted = tmp_path / "shifted.zarr"
    shutil.copytree(a, shifted)
    az = zarr.open_array(str(shifted / "sweep_0" / "azimuth"), mode="r+")
    az[:] = az[:] + 0.5
    for argv in (
        ["score", str(a), "--against", str(shifted)],
        ["compare", str(a), str(shifted)],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1
        assert "the azimuth grids differ" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "argv, says",
    [
        (["score", "{a}", "--by", "elevation"], "only azimuth"),
        (["score", "{a}", "--by", "azimuth:0"], "more than 0"),
        (["score", "{a}", "--by", "azimuth:x"], "number of degrees"),
        (["compare", "{a}"], "at least two stores"),
        (["score", "{a}", "--against", "{missing}"], "missing.zarr"),
    ],
)
def test_bad_options_are_one_line_exit_2(runs, tmp_path, capsys, argv, says):
    a = store(runs, "narrow", "estimate")
    argv = [x.format(a=a, missing=tmp_path / "missing.zarr") for x in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and says in err
