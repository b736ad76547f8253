"""A store knows its arrays: one removed whole is named, never read as NaN, and rewritten.

The layout a run writes first lists every array of the store (the root attribute
``pasim_arrays``, per sweep and root, the done flags included). ``pasim score``, ``pasim plot``
and ``pasim compare`` refuse a store that lacks one, naming it in one line with exit 2;
``--resume`` lays it out again and computes its chunks again, after which the store equals
the original file for file. A store written before the list (none in its root) is checked
against the arrays its consolidated metadata names. And ``--resume`` refuses a symbolic link
planted in a store instead of writing through it, outside the store.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from ..conftest import TINY_RUN as RUN
from ..conftest import pasim

LIST = "pasim_arrays"


def arrays(store: Path) -> list[str]:
    """The arrays in a store, by their metadata on disk."""
    return sorted(
        p.parent.relative_to(store).as_posix()
        for p in store.rglob("zarr.json")
        if json.loads(p.read_text()).get("node_type") == "array"
    )


def files(store: Path) -> dict[str, bytes]:
    """Every file of a store but its lock, by path; the root's metadata without its task
    record (each run, a resume too, adds its own timings to ``pasim_tasks``: the record of
    how the store was made, not of what it holds)."""
    out = {
        p.relative_to(store).as_posix(): p.read_bytes()
        for p in sorted(store.rglob("*"))
        if p.is_file() and p.name != "pasim-store.lock"
    }
    if "zarr.json" in out:
        meta = json.loads(out["zarr.json"])
        meta.get("attributes", {}).pop("pasim_tasks", None)
        out["zarr.json"] = json.dumps(meta, sort_keys=True).encode()
    return out


def same(a: Path, b: Path) -> None:
    """The same variables with the same values in every group, and the same files."""
    x = xr.open_datatree(a, engine="zarr")
    y = xr.open_datatree(b, engine="zarr")
    for group in ("/", "sweep_0"):
        dx, dy = x[group].to_dataset(), y[group].to_dataset()
        assert sorted(dx.variables) == sorted(dy.variables)
        for name in dx.variables:
            np.testing.assert_array_equal(dx[name].values, dy[name].values, err_msg=name)
    fa, fb = files(a), files(b)
    assert sorted(fa) == sorted(fb)
    assert [n for n in fa if fa[n] != fb[n]] == []


def copy_without(original: Path, tmp_path: Path, *removed: str) -> Path:
    store = tmp_path / "run.zarr"
    shutil.copytree(original, store)
    for name in removed:
        shutil.rmtree(store / name)
    return store


def test_the_layout_lists_every_array(original):
    listed = json.loads(json.loads((original / "zarr.json").read_text())["attributes"][LIST])
    assert listed == arrays(original)
    assert {"sweep_0/error_ZDR", "sweep_0/DBZH", "sweep_0/azimuth", "pasim_chunk_done"} <= set(
        listed
    )
    assert {"time_coverage_start", "latitude"} <= set(listed)


@pytest.mark.parametrize(
    "array", ["sweep_0/error_ZDR", "sweep_0/DBZH", "time_coverage_start", "pasim_chunk_done"]
)
def test_score_plot_and_compare_refuse_a_store_missing_an_array(original, tmp_path, capsys, array):
    store = copy_without(original, tmp_path, array)
    png = tmp_path / "p.png"
    for cmd in (
        ["score", str(store)],
        ["score", str(store), "--json"],
        ["plot", str(store), "--out", str(png)],
        ["compare", str(original), str(store)],
    ):
        code, err = pasim(capsys, *cmd)
        assert code == 2, (cmd, err)
        assert f"{store}: {array} is missing (the layout lists it)" in err, (cmd, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not png.exists()


@pytest.mark.parametrize(
    "removed",
    [
        ("sweep_0/error_ZDR",),
        ("sweep_0/DBZH", "sweep_0/IQ_V"),
        ("sweep_0/azimuth",),
        ("time_coverage_start", "latitude"),
        ("pasim_chunk_done",),
        ("sweep_0",),
    ],
    ids=lambda r: "+".join(r),
)
def test_resume_writes_a_missing_array_again(original, tmp_path, capsys, removed):
    """--resume lays the missing arrays out again and runs the chunks they hold again; the
    store then equals the original, value for value and file for file."""
    store = copy_without(original, tmp_path, *removed)
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 0, err
    assert "is already complete" not in err
    assert ("missing" in err) and all(r in err for r in removed if r != "sweep_0"), err
    same(store, original)
    assert pasim(capsys, "score", str(store))[0] == 0


def test_a_store_written_before_the_list_is_checked_against_its_consolidated_metadata(
    original, tmp_path, capsys
):
    store = copy_without(original, tmp_path)
    meta = json.loads((store / "zarr.json").read_text())
    meta["attributes"].pop(LIST, None)  # as a store written before the list
    (store / "zarr.json").write_text(json.dumps(meta))
    assert pasim(capsys, "score", str(store))[0] == 0  # it opens as before
    shutil.rmtree(store / "sweep_0" / "error_ZDR")
    code, err = pasim(capsys, "score", str(store))
    assert code == 2 and "sweep_0/error_ZDR is missing (the layout lists it)" in err, err
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 0, err
    np.testing.assert_array_equal(
        xr.open_datatree(store, engine="zarr")["sweep_0"]["error_ZDR"].values,
        xr.open_datatree(original, engine="zarr")["sweep_0"]["error_ZDR"].values,
    )


def test_resume_refuses_a_link_planted_in_the_store(original, tmp_path, capsys):
    """A link in place of a chunk file: --resume would rewrite the damaged chunk through it,
    replacing a file outside the store; it is refused, naming the link, and nothing moves."""
    store = copy_without(original, tmp_path)
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "0").write_text("precious")
    (store / "sweep_0" / "DBZH" / "c.1.0").unlink()
    (store / "sweep_0" / "DBZH" / "c.1.0").symlink_to(theirs / "0")
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 2, err
    assert "symbolic link" in err and "sweep_0/DBZH/c.1.0" in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    assert (theirs / "0").read_text() == "precious"
    assert sorted(p.name for p in theirs.iterdir()) == ["0"]
