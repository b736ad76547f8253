"""A run on a truth without some moments (the Rainbow sample holds reflectivity only): the
moments the truth lacks are neither scored nor drawn as if they had a truth. `pasim score`
lists them as "no truth", `pasim plot` marks their rows, the study report draws no panels
for them."""

from __future__ import annotations

import json

import pytest
import xarray as xr

from ..conftest import GRAPHS, ROOT, pasim_in_process, pasim_result

GENERIC = str(GRAPHS / "generic_radar.yaml")
RAINBOW = ROOT / "tests" / "fixtures" / "truth" / "2013051000000600dBZ.vol"
WITHOUT = ("ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp("rainbow") / "dbz_only.zarr"
    res = pasim_in_process(
        "run",
        GENERIC,
        "--truth",
        str(RAINBOW),
        "--sector",
        "0:2",
        "--set",
        "weather.method=expected",
        "--out",
        str(out),
    )
    assert res.returncode == 0, res.stderr
    return out


def sweep_of(store) -> xr.Dataset:
    return xr.open_datatree(store, engine="zarr")["sweep_0"].to_dataset()


def test_the_run_estimates_moments_its_truth_lacks(store):
    sweep = sweep_of(store)
    assert "truth_DBZH" in sweep and "VRADH" in sweep and "WRADH" in sweep
    assert not any(f"truth_{n}" in sweep for n in WITHOUT)


def test_score_lists_the_moments_without_truth(store, capsys):
    res = pasim_result(capsys, "score", str(store))
    assert res.returncode == 0, res.stderr
    rows = {line.split()[0]: line for line in res.stdout.splitlines() if line.strip()}
    for name in ("VRADH", "WRADH"):
        assert "no truth" in rows[name], res.stdout
        assert "nan" not in rows[name].lower()
    assert "no truth" not in rows["DBZH"]
    res = pasim_result(capsys, "score", str(store), "--json")
    scores = json.loads(res.stdout)
    assert scores["VRADH"] == {"no_truth": True, "count": 0}
    assert scores["WRADH"]["no_truth"] is True
    assert scores["DBZH"]["count"] > 0 and "no_truth" not in scores["DBZH"]


def _texts(ax) -> str:
    return " ".join([ax.get_title(), ax.get_ylabel(), *(t.get_text() for t in ax.texts)])


def test_plot_marks_the_rows_without_truth(store, tmp_path, capsys):
    from pasim_blocks.products.moment_figures import available, plot_store, store_figure

    sweep = sweep_of(store)
    names, notes = available(sweep)
    assert "VRADH" in names and any("VRADH" in n and "no truth" in n for n in notes)
    fig = store_figure(sweep, ["DBZH", "VRADH"])
    dbz, vel = fig.axes[0:3], [ax for ax in fig.axes if "VRADH" in _texts(ax)]
    assert "no truth" in vel[0].get_ylabel()  # the row title says it
    assert all("no truth" in _texts(ax) for ax in vel if ax.get_title())
    assert not any("no truth" in _texts(ax) for ax in dbz)
    out = tmp_path / "plot.png"
    notes = plot_store(store, out)
    assert out.stat().st_size > 10_000 and any("WRADH" in n for n in notes)
    res = pasim_result(capsys, "plot", str(store), "--out", str(tmp_path / "cli.png"))
    assert res.returncode == 0, res.stderr


def test_study_report_draws_no_panels_for_moments_without_truth(store):
    from pasim_blocks.study.panel_figures import ppi_fields, ppi_figure

    notes: list[str] = []
    panels = [("generic", sweep_of(store))]
    figures = [ppi_figure(n, panels) for n in ppi_fields(panels, notes, "rainbow")]
    assert [f.title.split(":")[0] for f in figures] == ["DBZH"]
    assert len(notes) == 1 and all(n in notes[0] for n in WITHOUT)
