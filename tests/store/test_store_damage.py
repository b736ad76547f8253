"""A store damaged after it was written is named, never read as wrong numbers, and repaired.

Chunks are written under a CRC-32C checksum, and every chunk is written (all-NaN ones too),
so flipping bytes in, truncating or removing any chunk file of a finished store is found by
``check_chunks``; ``pasim score`` and ``pasim plot`` then exit 2 naming the array and the
chunk, and ``pasim run ... --resume`` rewrites the damaged chunks, after which the store
equals the original array for array (compared with the undamaged copy, bit for bit).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pasim_graph.store import check_chunks

from ..conftest import TINY_RUN as RUN
from ..conftest import pasim


def chunk_files(store: Path) -> list[Path]:
    """Every chunk file of every array in the store (c.1.0: a file beside the array's
    metadata)."""
    return sorted(p for p in store.rglob("c*") if p.is_file() and p.name.split(".")[0] == "c")


def flip(path: Path) -> None:
    data = bytearray(path.read_bytes())
    at = len(data) // 2
    data[at : at + 16] = bytes(b ^ 0xA5 for b in data[at : at + 16])
    path.write_bytes(bytes(data))


def truncate(path: Path) -> None:
    os.truncate(path, path.stat().st_size // 2)


def remove(path: Path) -> None:
    path.unlink()


FAULTS = {"flip": flip, "truncate": truncate, "remove": remove}


def same(a: Path, b: Path) -> None:
    x = xr.open_datatree(a, engine="zarr")
    y = xr.open_datatree(b, engine="zarr")
    for group in ("/", "sweep_0"):
        dx, dy = x[group].to_dataset(), y[group].to_dataset()
        assert sorted(dx.variables) == sorted(dy.variables)
        for name in dx.variables:
            np.testing.assert_array_equal(dx[name].values, dy[name].values, err_msg=name)


# Every chunk file, one at a time, for each fault is 200-odd store copies: a flipped byte
# (the fault a checksum exists for) in the default suite, the other two with -m slow.
@pytest.mark.parametrize(
    "fault", [f if f == "flip" else pytest.param(f, marks=pytest.mark.slow) for f in sorted(FAULTS)]
)
def test_any_damaged_chunk_file_is_found(original, tmp_path, fault):
    """Every chunk file of the store, one at a time: the damage is named, array and chunk."""
    files = chunk_files(original)
    assert len(files) > 60
    assert check_chunks(original) == []
    # One copy of the store, each chunk file damaged in it and then put back as it was.
    store = tmp_path / "store"
    shutil.copytree(original, store)
    for file in files:
        rel = file.relative_to(original)
        FAULTS[fault](store / rel)
        found = check_chunks(store)
        node, key = rel.parent.as_posix(), rel.name
        assert [f"{d.node} {d.key}" for d in found] == [f"{node} {key}"], (
            f"{fault} {rel}: {[str(d) for d in found]}"
        )
        shutil.copy2(file, store / rel)
    assert check_chunks(store) == []


@pytest.mark.parametrize("fault", sorted(FAULTS))
@pytest.mark.parametrize("array", ["sweep_0/DBZH", "sweep_0/IQ_V", "pasim_chunk_done"])
def test_score_and_plot_refuse_then_resume_repairs(original, tmp_path, capsys, fault, array):
    store = tmp_path / "run.zarr"
    shutil.copytree(original, store)
    target = next(p for p in chunk_files(store / array) if p.name.split(".")[1] == "1")
    FAULTS[fault](target)
    key = target.name
    if array != "pasim_chunk_done":  # a damaged done flag hides no numbers: resume redoes it
        for cmd in (["score", str(store)], ["plot", str(store), "--out", str(tmp_path / "p.png")]):
            code, err = pasim(capsys, *cmd)
            assert code == 2, err
            assert "Traceback" not in err
            assert f"{array} chunk {key}" in err, err
        assert not (tmp_path / "p.png").exists()
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 0, err
    assert "rewriting 1 damaged chunk" in err
    assert check_chunks(store) == []
    same(store, original)
    assert pasim(capsys, "score", str(store))[0] == 0


def test_damaged_metadata_is_named_and_not_resumed(original, tmp_path, capsys):
    store = tmp_path / "run.zarr"
    shutil.copytree(original, store)
    (store / "sweep_0" / "ZDR" / "zarr.json").write_text('{"zarr_for')
    code, err = pasim(capsys, "score", str(store))
    assert code == 2 and "sweep_0/ZDR/zarr.json" in err, err
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 2 and "sweep_0/ZDR/zarr.json" in err and "--overwrite" in err, err
    assert "Traceback" not in err


def test_a_store_of_a_folder_a_chunk_is_still_checked_and_resumed(tmp_path, capsys, monkeypatch):
    """Stores written before 2026-11-29 keep each chunk in a folder (c/1/0, zarr's default
    key encoding); newer ones a file beside the metadata (c.1.0). The older kind is still
    accepted as this program's, its damage named by its own keys, and --resume repairs it."""
    import pasim_graph.store.layout as layout
    from pasim_graph.store.format import encoding

    def nested(dtype):
        return {**encoding(dtype), "chunk_key_encoding": {"name": "default", "separator": "/"}}

    monkeypatch.setattr(layout, "encoding", nested)
    reference = tmp_path / "reference.zarr"
    assert pasim(capsys, *RUN, "--out", str(reference))[0] == 0
    monkeypatch.undo()
    chunk = reference / "sweep_0" / "DBZH" / "c" / "1" / "0"
    assert chunk.is_file() and not list((reference / "sweep_0" / "DBZH").glob("c.*"))
    assert check_chunks(reference) == []
    store = tmp_path / "run.zarr"
    shutil.copytree(reference, store)
    (store / "sweep_0" / "DBZH" / "c" / "1" / "0").unlink()
    assert [str(d) for d in check_chunks(store)] == ["sweep_0/DBZH chunk c/1/0 (missing)"]
    code, err = pasim(capsys, *RUN, "--out", str(store), "--resume")
    assert code == 0, err
    assert "rewriting 1 damaged chunk" in err
    assert (store / "sweep_0" / "DBZH" / "c" / "1" / "0").is_file()
    assert check_chunks(store) == []
    same(store, reference)
