"""``pasim export``: a finished run as CF/Radial 1, CF/Radial 2 and ODIM_H5 (issue 39).

Each file of a two-sweep volume (a tiny uniform scene with censored gates by default; the
bundled storm's KLBB volume, with its no-data truth gates, in a slow test) is read back by
xradar and by Py-ART (independent readers: xradar's CF/Radial 1 and ODIM backends,
``xarray.open_datatree`` for CF/Radial 2, ``pyart.io.read_cfradial``, Py-ART's xradar bridge
and ``pyart.aux_io.read_odim_h5``) and every sweep's six moments and six truth fields are
compared with the store's: bit for bit in CF/Radial (float32 in, float32 out), and within half the
stated gain in ODIM_H5 (16-bit integers; the bound is the quantisation's, plus float32
rounding). Bad input is refused in one line with nothing written.
"""

from __future__ import annotations

import os
import shutil
import warnings

import numpy as np
import pytest
import xarray as xr

from ..conftest import FIXTURES, GRAPHS, pasim

MOMENTS = ["DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"]
FIELDS = MOMENTS + [f"truth_{m}" for m in MOMENTS]
FORMATS = ["cfradial1", "cfradial2", "odim"]
#: Two cuts (0.5 and 1.5 deg) of two beams and 12 gates over a uniform scene, received at 3 dB
#: SNR so that the processor censors about a third of the gates (NaN in the store).
TINY = ["run", str(FIXTURES / "tiny_volume.yaml")]
#: Two PPI cuts of the bundled KLBB volume over a 2-degree sector (its own elevations).
STORM = [
    "run",
    str(GRAPHS / "generic_vcp212.yaml"),
    "--sector",
    "240:242",
    "--set",
    "scan.preset=''",
    "--set",
    "scan.cuts=0.5 0.0031 16; 1.5 0.001 16",
    "--set",
    "truth.elevation_max_deg=1.5",
]


def _run(args: list[str], out) -> None:
    from pasim_graph.cli import main

    assert main([*args, "--out", str(out)]) == 0


def _export(volume) -> dict[str, object]:
    """Each format's file of a volume, written through the command line."""
    from pasim_graph.cli import main

    files = {}
    for fmt in FORMATS:
        files[fmt] = volume.parent / f"{volume.stem}.{fmt}"
        assert main(["export", str(volume), "--format", fmt, "--out", str(files[fmt])]) == 0
    return files


@pytest.fixture(scope="module")
def volume(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "tiny.zarr"
    _run(TINY, out)
    return out


@pytest.fixture(scope="module")
def exported(volume):
    return _export(volume)


def _store_sweeps(volume) -> list[xr.Dataset]:
    tree = xr.open_datatree(volume, engine="zarr")
    return [tree[f"sweep_{i}"].to_dataset().load() for i in range(len(tree.children))]


def _bound(fmt: str, name: str) -> float:
    from pasim_blocks.products.exchange_files import odim_bound

    return odim_bound(name) if fmt == "odim" else 0.0


def _same(got: np.ndarray, want: np.ndarray, bound: float, what: str) -> None:
    """The same gates hold data (NaN where the store's is NaN) and values within ``bound``."""
    got = np.asarray(got, dtype=np.float64)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=f"{what}: no-data gates")
    assert np.isfinite(want).any(), what
    error = np.nanmax(np.abs(got - want))
    assert error <= bound, f"{what}: off by {error} (bound {bound})"


def _read_xradar(fmt: str, path) -> list[xr.Dataset]:
    import xradar

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if fmt == "cfradial1":
            tree = xradar.io.open_cfradial1_datatree(str(path))
        elif fmt == "cfradial2":
            tree = xr.open_datatree(str(path))
        else:
            tree = xradar.io.open_odim_datatree(str(path))
    names = sorted((n for n in tree.children if n.startswith("sweep_")), key=lambda n: int(n[6:]))
    return [tree[n].to_dataset().load() for n in names]


def _check_xradar(fmt: str, volume, path) -> None:
    store = _store_sweeps(volume)
    read = _read_xradar(fmt, path)
    assert len(read) == len(store) == 2
    for k, (want, got) in enumerate(zip(store, read, strict=True)):
        want, got = want.sortby("azimuth"), got.sortby("azimuth")
        np.testing.assert_allclose(got["azimuth"], want["azimuth"], atol=1e-4)
        np.testing.assert_allclose(got["elevation"], want["elevation"], atol=1e-4)
        np.testing.assert_allclose(got["range"], want["range"])
        for name in FIELDS:
            _same(got[name].values, want[name].values, _bound(fmt, name), f"sweep_{k} {name}")


def _check_pyart(fmt: str, volume, path) -> None:
    import pyart

    path = str(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if fmt == "cfradial1":
            radar = pyart.io.read_cfradial(path)
        elif fmt == "cfradial2":
            radar = xr.open_datatree(path).pyart.to_radar()
        else:
            radar = pyart.aux_io.read_odim_h5(path, file_field_names=True)
    store = _store_sweeps(volume)
    assert radar.nsweeps == len(store) == 2
    assert set(FIELDS) <= set(radar.fields)
    for k, want in enumerate(store):
        rays = radar.get_slice(k)
        azimuth = radar.azimuth["data"][rays] % 360.0  # Py-ART's ODIM reader gives -180 to 180
        order = np.argsort(azimuth)
        want = want.sortby("azimuth")
        np.testing.assert_allclose(azimuth[order], want["azimuth"], atol=1e-4)
        np.testing.assert_allclose(radar.elevation["data"][rays], want["elevation"], atol=1e-4)
        np.testing.assert_allclose(radar.fixed_angle["data"][k], want["sweep_fixed_angle"])
        for name in FIELDS:
            if fmt != "odim":  # ODIM_H5 has no units or names beyond the quantity's own
                assert radar.fields[name]["units"] == want[name].attrs["units"], name
            data = radar.fields[name]["data"][rays][order][:, : want.sizes["range"]]
            got = np.ma.filled(np.ma.asarray(data).astype(np.float64), np.nan)
            _same(got, want[name].values, _bound(fmt, name), f"sweep {k} {name}")


@pytest.mark.parametrize("fmt", FORMATS)
def test_xradar_reads_every_sweep_with_the_moments_and_the_truth(fmt, volume, exported):
    _check_xradar(fmt, volume, exported[fmt])


@pytest.mark.parametrize("fmt", FORMATS)
def test_pyart_reads_every_sweep_with_the_moments_and_the_truth(fmt, volume, exported):
    _check_pyart(fmt, volume, exported[fmt])


@pytest.mark.slow
def test_the_storm_volume_reads_back_in_every_format(tmp_path):
    """The same checks on the bundled storm: real truth, with no-data gates of its own."""
    store = tmp_path / "klbb.zarr"
    _run(STORM, store)
    files = _export(store)
    for fmt in FORMATS:
        _check_xradar(fmt, store, files[fmt])
        _check_pyart(fmt, store, files[fmt])
    truth = _store_sweeps(store)[0]["truth_DBZH"].values
    assert np.isnan(truth).any() and np.isfinite(truth).any()


def test_a_truth_field_says_it_is_the_truth(exported):
    """In CF/Radial the truth keeps its moment's standard name and units, but its short and
    long names are its own, never the estimate's (a tool going by them takes the right one)."""
    import netCDF4

    with netCDF4.Dataset(exported["cfradial1"]) as f:
        for moment in MOMENTS:
            estimate, truth = f[moment], f[f"truth_{moment}"]
            assert truth.standard_name == estimate.standard_name
            assert truth.units == estimate.units
            assert truth.short_name == f"truth_{moment}" and estimate.short_name == moment
            assert truth.long_name == f"{estimate.long_name}, truth (simulation input)"


def test_odim_holds_16_bit_integers_with_the_stated_gain(exported):
    """What the ODIM bound rests on, read with h5py: every field a uint16 array whose
    what/gain and what/offset are the coding the exporter states, nodata 65535."""
    import h5py
    from pasim_blocks.products.exchange_files import ODIM_CODING

    with h5py.File(exported["odim"]) as f:
        assert f["what"].attrs["object"] == b"PVOL"
        quantities = []
        for ds in ("dataset1", "dataset2"):
            for key in f[ds]:
                if not key.startswith("data"):
                    continue
                what = f[ds][key]["what"].attrs
                name = what["quantity"].decode()
                gain, offset = ODIM_CODING[name.removeprefix("truth_")]
                assert f[ds][key]["data"].dtype == np.uint16
                assert (what["gain"], what["offset"], what["nodata"]) == (gain, offset, 65535)
                quantities.append(name)
    assert sorted(quantities) == sorted(FIELDS * 2)


def _listing(folder) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.parametrize(
    "case",
    [
        "not a store",
        "no such store",
        "unknown format",
        "existing output",
        "missing folder",
        "incomplete",
    ],
)
def test_bad_input_is_refused_in_one_line_and_nothing_is_written(case, volume, tmp_path, capsys):
    from pasim_graph.store import mark_incomplete

    store, fmt, out = str(volume), "odim", tmp_path / "out.h5"
    if case == "not a store":
        (tmp_path / "notes").mkdir()
        (tmp_path / "notes" / "a.txt").write_text("hello")
        store = str(tmp_path / "notes")
    elif case == "no such store":
        store = str(tmp_path / "missing.zarr")
    elif case == "unknown format":
        fmt = "netcdf"
    elif case == "existing output":
        out.write_text("keep me")
    elif case == "missing folder":
        out = tmp_path / "nowhere" / "out.h5"
    elif case == "inside the store":
        shutil.copytree(volume, tmp_path / "copy.zarr")
        store, out = str(tmp_path / "copy.zarr"), tmp_path / "copy.zarr" / "out.h5"
    else:
        shutil.copytree(volume, tmp_path / "copy.zarr")
        store = str(tmp_path / "copy.zarr")
        mark_incomplete(store)
    before = _listing(tmp_path)
    code, err = pasim(capsys, "export", store, "--format", fmt, "--out", str(out))
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert _listing(tmp_path) == before
    if case == "existing output":
        assert out.read_text() == "keep me"
    expected = {
        "not a store": "not a PASIM-graph store",
        "no such store": "no such store",
        "unknown format": "expected one of cfradial1, cfradial2, odim",
        "existing output": "exists",
        "missing folder": "does not exist",
        "inside the store": "is inside the store",
        "incomplete": "did not finish",
    }[case]
    assert expected in err


def test_a_write_that_fails_leaves_no_file(volume, tmp_path, monkeypatch, capsys):
    """A full disk while the writer writes: one line naming --out, the partial file gone."""
    import errno

    from pasim_blocks.products import exchange_files

    def full(tree, fmt, path):
        path.write_bytes(b"half a file")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(exchange_files, "_write", full)
    out = tmp_path / "out.nc"
    code, err = pasim(capsys, "export", str(volume), "--format", "cfradial1", "--out", str(out))
    assert code == 2 and err.count("\n") == 1, err
    assert f"--out {out}: could not write cfradial1" in err and "No space left" in err
    assert os.listdir(tmp_path) == []


def test_without_out_the_file_is_named_after_the_store(volume, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code, err = pasim(capsys, "export", str(volume), "--format", "cfradial2")
    assert code == 0, err
    assert os.listdir(tmp_path) == ["tiny_cfradial2.nc"]
    assert "2 sweep(s)" in err and "truth_DBZH" in err


def test_a_value_odim_cannot_code_is_refused():
    """ODIM's uint16 DBZH holds -327.67 to 327.66 dBZ: 400 dBZ is refused, not wrapped."""
    from pasim_blocks.products.exchange_files import ExportError, odim_encode

    sweep = xr.Dataset({"DBZH": (("azimuth", "range"), np.array([[10.0, 400.0]], np.float32))})
    tree = xr.DataTree.from_dict({"/": xr.Dataset(), "sweep_0": sweep})
    with pytest.raises(ExportError, match="sweep_0/DBZH spans 10 to 400"):
        odim_encode(tree, "x.zarr")


def test_an_rhi_is_refused_for_odim():
    """ODIM_H5's polar volume holds PPIs: an RHI is refused for it, naming the formats that
    hold one."""
    from pasim_blocks.products.exchange_files import ExportError, check_odim_scans

    sweep = xr.Dataset({"sweep_mode": "rhi"})
    tree = xr.DataTree.from_dict({"/": xr.Dataset(), "sweep_0": sweep})
    with pytest.raises(ExportError, match=r"sweep_0 is an RHI.*cfradial1 or cfradial2"):
        check_odim_scans(tree, "x.zarr")
    check_odim_scans(
        xr.DataTree.from_dict({"sweep_0": xr.Dataset({"sweep_mode": "azimuth_surveillance"})}),
        "x.zarr",
    )
