"""A chunk's region is written with zarr directly where its values are its stored bytes, and
through xarray's ``to_zarr`` otherwise (CF-encoded times): both read back through xarray as
what was computed, every chunk file exists (even an all-NaN one), and the chunk is flagged.

The independent reference is xarray itself: the same chunks written by ``Dataset.to_zarr``
with a region into a second store laid out the same way.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from pasim_graph.store import create_volume, run_state, write_region

BEAMS, GATES, CHUNK = 6, 5, 3


def chunk(start: int) -> xr.Dataset:
    az = np.arange(start, start + CHUNK, dtype=np.float64)
    rng = np.random.default_rng(start)
    dbz = rng.normal(20, 5, (CHUNK, GATES)).astype(np.float32)
    if start:
        dbz[:] = np.nan  # a chunk of no data is still written (check_chunks)
    iq = (rng.normal(size=(CHUNK, GATES)) + 1j * rng.normal(size=(CHUNK, GATES))).astype(
        np.complex64
    )
    when = np.datetime64("2016-06-01T15:00:25", "ns") + (az * 1e9).astype("timedelta64[ns]")
    return xr.Dataset(
        {
            "DBZH": (("azimuth", "range"), dbz, {"units": "dBZ"}),
            "iq": (("azimuth", "range"), iq),
            "scored": (("azimuth", "range"), (dbz > 20).astype(np.int8)),
            "beam_time": (("azimuth",), when),
            "site": ((), np.float64(1.5)),
        },
        coords={"azimuth": az, "range": np.arange(GATES) * 250.0},
    )


def lay_out(path) -> None:
    first = chunk(0)
    coords = {"azimuth": xr.Variable("azimuth", np.arange(BEAMS, dtype=np.float64))}
    create_volume(path, xr.Dataset(attrs={"title": "t"}), first, coords, BEAMS, CHUNK, 2)


def test_direct_and_xarray_writes_read_back_as_computed(tmp_path):
    ours, theirs = tmp_path / "ours.zarr", tmp_path / "theirs.zarr"
    lay_out(ours)
    lay_out(theirs)
    for index, start in enumerate((0, CHUNK)):
        ds = chunk(start)
        write_region(ours, ds, start, index)
        region = ds.drop_vars(["azimuth", "range", "site"])
        region.to_zarr(theirs, group="sweep_0", region={"azimuth": slice(start, start + CHUNK)})
    a = xr.open_datatree(ours, engine="zarr")["sweep_0"].to_dataset()
    b = xr.open_datatree(theirs, engine="zarr")["sweep_0"].to_dataset()
    for name in ("DBZH", "iq", "scored", "beam_time"):
        assert a[name].dtype == b[name].dtype, name
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    assert np.isnan(a["DBZH"].values[CHUNK:]).all()
    assert np.iscomplexobj(a["iq"].values) and np.abs(a["iq"].values.imag).sum() > 0
    assert a["beam_time"].values[1] == np.datetime64("2016-06-01T15:00:26", "ns")
    for name in ("DBZH", "iq", "scored", "beam_time"):
        files = sorted(p.name for p in (ours / "sweep_0" / name).glob("c.*") if p.is_file())
        assert len(files) == 2, (name, files)
    state = run_state(ours)
    assert state is not None and state[1].tolist() == [1, 1]


def test_chunk_files_are_the_bytes_zarr_writes(tmp_path):
    """Whole chunks are encoded here rather than by zarr's asynchronous pipeline: every chunk
    file must be the bytes zarr itself writes for the same values (the reference: the same
    regions written by zarr's own ``Array.__setitem__`` into arrays laid out the same way),
    for each dtype a store holds, a 3-D cube, a last chunk sticking out of the array, and a
    region of two chunks. A region that cuts a chunk goes to zarr and reads back too."""
    import zarr
    from zarr.core.sync import sync

    from pasim_graph.store import encoding
    from pasim_graph.store.writes import write_arrays

    rng = np.random.default_rng(7)
    cases = {
        "f4": ((7, 5), (3, 5), np.float32),
        "c8": ((7, 5), (3, 5), np.complex64),
        "i1": ((7, 5), (3, 5), np.int8),
        "f8": ((7,), (3,), np.float64),
        "cube": ((7, 4, 5), (3, 4, 5), np.complex64),
    }
    regions = [slice(0, 3), slice(3, 6), slice(6, 7)]  # the last sticks out of its chunk
    for name, (shape, chunks, dtype) in cases.items():
        arrays = []
        for which in ("ours", "zarr"):
            arrays.append(
                zarr.create_array(
                    str(tmp_path / which),
                    name=name,
                    shape=shape,
                    chunks=chunks,
                    **encoding(np.dtype(dtype)),
                )
            )
        ours, theirs = arrays
        stored = sync(zarr.api.asynchronous.open_array(store=str(tmp_path / "ours"), path=name))
        values = rng.normal(size=shape) * 50
        if np.dtype(dtype).kind == "c":
            values = values + 1j * rng.normal(size=shape)
        values = values.astype(dtype)
        if np.dtype(dtype).kind == "f":
            values[0, ...] = np.nan  # a row of no data
        for beams in [*regions, slice(0, 6)]:
            where = (beams,) + (slice(None),) * (len(shape) - 1)
            write_arrays([(stored, where, values[where])])
            theirs.with_config({"write_empty_chunks": True})[where] = values[where]
        files = sorted(
            p.relative_to(tmp_path / "ours") for p in (tmp_path / "ours" / name).rglob("*")
        )
        assert len([f for f in files if (tmp_path / "ours" / f).is_file()]) == 4, name
        for f in files:
            a, b = tmp_path / "ours" / f, tmp_path / "zarr" / f
            assert a.is_file() == b.is_file(), (name, f)
            if a.is_file():
                assert a.read_bytes() == b.read_bytes(), (name, f)
        np.testing.assert_array_equal(ours[...], values, err_msg=name)
    # A region cutting a chunk: zarr merges it into the chunk's stored values.
    stored = sync(zarr.api.asynchronous.open_array(store=str(tmp_path / "ours"), path="f4"))
    before = zarr.open_array(str(tmp_path / "ours"), path="f4")[...]
    write_arrays([(stored, (slice(1, 2), slice(None)), np.full((1, 5), 9, np.float32))])
    before[1] = 9
    np.testing.assert_array_equal(zarr.open_array(str(tmp_path / "ours"), path="f4")[...], before)


def test_a_new_layout_under_a_new_run_token_is_opened_afresh(tmp_path):
    """A run's arrays are opened once per process and kept for its token; an overwritten
    store laid out again (other dtypes, another size) is written under a fresh token, and
    must be written by its new arrays, not the kept ones."""
    path = tmp_path / "s.zarr"
    lay_out(path)
    write_region(path, chunk(0), 0, 0, run="first")
    import shutil

    shutil.rmtree(path)
    first = chunk(0)
    shifted = first.assign_coords(azimuth=first.azimuth + CHUNK)
    wider = xr.concat([first, shifted], "azimuth", data_vars="minimal", coords="minimal")
    wider["DBZH"] = wider["DBZH"].astype(np.float64)
    coords = {"azimuth": xr.Variable("azimuth", np.arange(2 * BEAMS, dtype=np.float64))}
    create_volume(path, xr.Dataset(attrs={"title": "t"}), wider, coords, 2 * BEAMS, 2 * CHUNK, 2)
    write_region(path, wider, 0, 0, run="second")
    back = xr.open_datatree(path, engine="zarr")["sweep_0"].to_dataset()
    assert back["DBZH"].dtype == np.float64
    np.testing.assert_array_equal(back["DBZH"].values[: 2 * CHUNK], wider["DBZH"].values)
    assert run_state(path)[1].tolist() == [1, 0]


def test_a_chunk_file_is_replaced_whole_or_not_at_all(tmp_path):
    """Chunk files of a local store are written in the calling thread (``put_file``), as
    zarr's LocalStore writes them: into a fresh file beside the target, renamed over it. A
    write that fails leaves the old bytes and no partial file; a missing folder is made."""
    from pasim_graph.store.writes import put_file

    target = tmp_path / "a" / "c" / "0" / "0"
    put_file(str(target), b"first")  # its folders do not exist yet
    assert target.read_bytes() == b"first"

    class Broken:
        def __buffer__(self, flags):
            raise OSError("disk full")

    try:
        put_file(str(target), Broken())
    except (OSError, TypeError):
        pass
    else:
        raise AssertionError("a failed write must raise")
    assert target.read_bytes() == b"first"
    assert sorted(p.name for p in target.parent.iterdir()) == ["0"]


def test_a_store_not_on_local_disk_is_written_through_zarr(tmp_path):
    """Only zarr's own LocalStore is written file by file here; any other store (memory,
    fsspec's remote ones) takes zarr's path and reads back the same."""
    import zarr
    from zarr.core.sync import sync
    from zarr.storage import MemoryStore

    from pasim_graph.store import encoding
    from pasim_graph.store.writes import write_arrays

    store = MemoryStore()
    zarr.create_array(store, name="v", shape=(6, 5), chunks=(3, 5), **encoding(np.float32))
    stored = sync(zarr.api.asynchronous.open_array(store=store, path="v"))
    values = np.arange(30, dtype=np.float32).reshape(6, 5)
    write_arrays([(stored, (slice(0, 3), slice(None)), values[:3])])
    back = zarr.open_array(store, path="v")[...]
    np.testing.assert_array_equal(back[:3], values[:3])
    assert np.isnan(back[3:]).all()
    assert not list(tmp_path.iterdir())  # nothing went to disk


def test_a_failed_file_among_many_is_raised_once_all_have_ended(tmp_path, monkeypatch):
    """A call's files are written by two threads (``put_files``); a failure in either half is
    raised, and only once the other half has ended (nothing left writing behind the caller)."""
    import threading
    import time

    import pasim_graph.store.writes as writes

    real, ended = writes.put_file, []

    def put(path, data):
        if path.endswith("f4"):  # in the caller's half, while the helper still writes
            raise OSError(28, "No space left on device")
        time.sleep(0.05)
        real(path, data)
        ended.append((path, threading.current_thread().name))

    monkeypatch.setattr(writes, "put_file", put)
    files = [(str(tmp_path / f"f{i}"), b"x") for i in range(6)]
    try:
        writes.put_files(files)
    except OSError as exc:
        assert exc.errno == 28
    else:
        raise AssertionError("the failure must be raised")
    helper = [p for p, t in ended if t.startswith("pasim-writes")]
    assert helper == [f for f, _ in files[:3]]  # all of the helper's half, before the raise
    assert [p for p, t in ended if p not in helper] == [files[3][0]]
    monkeypatch.setattr(writes, "put_file", real)
    writes.put_files(files)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"f{i}" for i in range(6)]
