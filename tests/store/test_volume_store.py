"""A run of a scan with several sweeps: one FM-301 store with sweep_0 ... sweep_N, each with its
own PRT and pulses (its I/Q cube its own shape), time on target stored and reported, scores per
sweep and pooled (checked against a pooling worked out here), the same numbers whatever the
chunking, and resume repairing a damaged chunk, or an array removed whole, of a later
sweep."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import xarray as xr

from pasim_graph import Chunk
from pasim_graph.fm301 import sweep_names
from pasim_graph.scores import TIME_ON_TARGET, volume_scores

from ..conftest import GRAPHS, pasim_in_process, pasim_out, pasim_result

CUTS = "0.5 0.0031 16; 1.5 0.001 32; 3.4 0.0012 24 243:245"
#: (elevation, PRT, pulses, beams) of each cut over the sector 240:246.
EXPECTED = [(0.5, 0.0031, 16, 6), (1.5, 0.001, 32, 6), (3.4, 0.0012, 24, 2)]
ARGS = [
    "run",
    "graphs/generic_vcp212.yaml",
    "--sector",
    "240:246",
    "--set",
    "scan.preset=''",
    "--set",
    f"scan.cuts={CUTS}",
    "--set",
    "truth.elevation_max_deg=3.4",
    "--save-iq",
]


def _open(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return xr.open_datatree(path, engine="zarr")


@pytest.fixture(scope="module")
def volume(tmp_path_factory):
    out = tmp_path_factory.mktemp("volume") / "store"
    done = pasim_in_process(*ARGS, "--chunk", "4", "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out, done.stdout


def test_every_cut_is_a_sweep_with_its_own_prt_and_pulses(volume):
    tree = _open(volume[0])
    assert sweep_names(tree) == ["sweep_0", "sweep_1", "sweep_2"]
    for k, (el, prt, pulses, beams) in enumerate(EXPECTED):
        ds = tree[f"sweep_{k}"].to_dataset()
        assert int(ds["sweep_number"]) == k
        assert ds.sizes["azimuth"] == beams
        np.testing.assert_allclose(ds["elevation"].values, el)
        np.testing.assert_allclose(ds["prt"].values, prt)
        assert int(ds["pulses"]) == pulses
        iq = next(v for n, v in ds.data_vars.items() if "pulse" in v.dims)
        assert iq.sizes["pulse"] == pulses, iq.name
    # Sweeps follow each other: each starts after the one before ends.
    starts = [tree[n]["time"].values.min() for n in sweep_names(tree)]
    assert starts == sorted(starts) and len(set(starts)) == 3


def test_time_on_target_is_the_sum_of_the_dwells(volume):
    """Stored on the root and each sweep, and printed: the sum over beams of pulses x PRT
    (worked out here from the cuts)."""
    path, stdout = volume
    tree = _open(path)
    each = [beams * pulses * prt for _, prt, pulses, beams in EXPECTED]
    for k, t in enumerate(each):
        assert tree[f"sweep_{k}"].attrs[TIME_ON_TARGET] == pytest.approx(t)
    assert tree.attrs[TIME_ON_TARGET] == pytest.approx(sum(each))
    assert f"volume (3 sweeps, time on target {sum(each):.3f} s)" in stdout
    assert f"sweep_2 (azimuth_surveillance at 3.4 deg, 2 beams, time on target {each[2]:.3f}" in (
        stdout
    )


def test_volume_scores_pool_every_sweeps_gates(volume):
    """The volume's DBZH bias and std are those of every sweep's DBZH errors put together
    (numpy here), and each sweep's are its own."""
    tree = _open(volume[0])
    scores = volume_scores(tree)
    errors = [tree[n]["error_DBZH"].values.ravel().astype(np.float64) for n in sweep_names(tree)]
    errors = [e[np.isfinite(e)] for e in errors]
    pooled = np.concatenate(errors)
    assert scores["scores"]["DBZH"]["count"] == pooled.size
    assert scores["scores"]["DBZH"]["bias"] == pytest.approx(pooled.mean())
    assert scores["scores"]["DBZH"]["std"] == pytest.approx(pooled.std(ddof=1))
    for n, e in zip(sweep_names(tree), errors, strict=True):
        assert scores["sweeps"][n]["scores"]["DBZH"]["bias"] == pytest.approx(e.mean())


def test_score_command_reports_each_sweep_and_the_volume(volume, capsys):
    import json

    code, out, err = pasim_out(capsys, "score", str(volume[0]))
    assert code == 0, err
    assert out.count("moment ") == 4  # three sweeps and the volume
    code, out, err = pasim_out(capsys, "score", str(volume[0]), "--json")
    data = json.loads(out)
    assert set(data["sweeps"]) == {"sweep_0", "sweep_1", "sweep_2"}
    assert data["time_on_target_s"] == pytest.approx(sum(b * m * t for _, t, m, b in EXPECTED))


def test_score_against_and_compare_name_the_sweep_of_a_volume(volume, capsys):
    # Only one sweep is compared at a time: a volume must say which (its first sweep alone
    # would pass for the whole volume).
    import json

    path = str(volume[0])
    for argv in (("score", path, "--against", path), ("compare", path, path)):
        code, _, err = pasim_out(capsys, *argv)
        assert code == 2 and "a volume of 3 sweeps" in err and "--sweep N" in err, err
    code, out, err = pasim_out(capsys, "score", path, "--against", path, "--sweep", "2", "--json")
    assert code == 0, err
    dbz = json.loads(out)["DBZH"]
    stored = _open(volume[0])["sweep_2"].to_dataset()["error_DBZH"].values
    assert dbz["count"] == int(np.isfinite(stored).sum()) > 0
    assert dbz["bias"] == 0.0 and dbz["std"] == 0.0  # a sweep against itself
    code, out, err = pasim_out(capsys, "compare", path, path, "--sweep", "2", "--json")
    assert code == 0, err
    code, _, err = pasim_out(capsys, "score", path, "--sweep", "1")
    assert code == 2 and "--sweep goes with --against or --by" in err
    code, _, err = pasim_out(capsys, "score", path, "--against", path, "--sweep", "5")
    assert code == 2 and "no sweep 5" in err, err


def test_plot_says_which_sweep_of_a_volume_it_drew(volume, capsys, tmp_path):
    out = tmp_path / "sweep1.png"
    code, _, err = pasim_out(
        capsys, "plot", str(volume[0]), "--fields", "DBZH", "--sweep", "1", "--out", str(out)
    )
    assert code == 0, err
    assert "drew sweep 1 of the volume's 3 (--sweep N for another)" in err
    assert out.stat().st_size > 10_000


def test_sweeps_draw_their_own_random_streams():
    """Beam indices restart in each sweep: the sweep keys the streams, and the first sweep's
    are a one-sweep scan's."""
    one = Chunk(beams=np.arange(1), block_name="weather")
    first = Chunk(beams=np.arange(1), block_name="weather", sweep=0)
    second = Chunk(beams=np.arange(1), block_name="weather", sweep=1)
    assert one.rng(3).random() == first.rng(3).random()
    assert second.rng(3).random() != first.rng(3).random()
    assert second.rng(3).random() != first.rng(3, 1).random()


def test_chunking_does_not_change_any_sweep(volume, tmp_path, capsys):
    other = tmp_path / "store"
    code, _, err = pasim_out(capsys, *ARGS, "--chunk", "3", "--out", str(other))
    assert code == 0, err
    a, b = _open(volume[0]), _open(other)
    for name in sweep_names(a):
        x, y = a[name].to_dataset(), b[name].to_dataset()
        for var in x.data_vars:
            np.testing.assert_array_equal(x[var].values, y[var].values, err_msg=f"{name}/{var}")


def test_resume_rewrites_a_damaged_chunk_of_a_later_sweep(volume, tmp_path, capsys):
    copy = tmp_path / "store"
    shutil.copytree(volume[0], copy)
    chunk = copy / "sweep_1" / "DBZH" / "c.1.0"
    assert chunk.is_file()
    chunk.unlink()
    code, _, err = pasim_out(capsys, "score", str(copy))
    assert code == 2 and "sweep_1/DBZH" in err
    code, _, err = pasim_out(capsys, *ARGS, "--chunk", "4", "--out", str(copy), "--resume")
    assert code == 0, err
    assert "rewriting 1 damaged chunk(s)" in err and "sweep 1, beams 4-5" in err
    assert "1 of 5 chunks" in err
    np.testing.assert_array_equal(
        _open(copy)["sweep_1"]["DBZH"].values, _open(volume[0])["sweep_1"]["DBZH"].values
    )
    # A finished store is left as it is.
    code, _, err = pasim_out(capsys, *ARGS, "--chunk", "4", "--out", str(copy), "--resume")
    assert code == 0 and "already complete" in err


def test_resume_writes_again_an_array_removed_from_a_later_sweep(volume, tmp_path, capsys):
    """sweep_2/DBZH removed whole: named by pasim score; --resume lays it out again and runs
    that sweep's one chunk only, and the volume equals the original."""
    copy = tmp_path / "store"
    shutil.copytree(volume[0], copy)
    shutil.rmtree(copy / "sweep_2" / "DBZH")
    code, _, err = pasim_out(capsys, "score", str(copy))
    assert code == 2 and "sweep_2/DBZH is missing (the layout lists it)" in err, err
    code, _, err = pasim_out(capsys, *ARGS, "--chunk", "4", "--out", str(copy), "--resume")
    assert code == 0, err
    assert "sweep_2/DBZH" in err and "1 of 5 chunks" in err, err
    a, b = _open(copy), _open(volume[0])
    for name in sweep_names(b):
        for var in b[name].to_dataset().variables:
            np.testing.assert_array_equal(
                a[name][var].values, b[name][var].values, err_msg=f"{name}/{var}"
            )


def test_the_vcp212_example_declares_every_cut():
    """graphs/generic_vcp212.yaml: the 17 rotations of VCP 212 (14 angles, three split cuts)
    over the 90 deg sector, each its own sweep."""
    from pasim_graph import load
    from pasim_graph.sweeps import sweep_overrides

    sweeps = sweep_overrides(load(GRAPHS / "generic_vcp212.yaml"))
    assert len(sweeps) == 17 and len({s["elevation_deg"] for s in sweeps}) == 14
    assert [s["elevation_deg"] for s in sweeps[:2]] == [0.5, 0.5]


@pytest.mark.slow
def test_vcp212_over_the_bundled_volume_writes_and_scores_every_cut(tmp_path, capsys):
    """The whole example (1,530 beams, about 3.5 min here): 17 sweeps, each scored."""
    import json

    out = tmp_path / "vcp212"
    done = pasim_result(capsys, "run", str(GRAPHS / "generic_vcp212.yaml"), "--out", str(out))
    assert done.returncode == 0, done.stderr
    data = json.loads(pasim_result(capsys, "score", str(out), "--json").stdout)
    assert len(data["sweeps"]) == 17
    # Every cut scored. The highest (19.5 deg) leaves the storm within a few km and scores
    # 750 gates, as measured when the example landed (docs/scans.md); the lowest 35,298.
    counts = [s["scores"]["DBZH"]["count"] for s in data["sweeps"].values()]
    assert min(counts) > 500 and max(counts) > 30_000, counts


def test_resume_runs_only_the_chunks_not_flagged_done_in_any_sweep(volume, tmp_path, capsys):
    """A run stopped with sweep 0 written and sweep 2 not: its done flags say so (the last
    chunk of each sweep cleared here, as a kill would leave them); --resume runs those two
    chunks only, and the store equals the uninterrupted one."""
    import zarr

    from pasim_graph.store import DONE, mark_incomplete

    copy = tmp_path / "store"
    shutil.copytree(volume[0], copy)
    mark_incomplete(copy)
    flags = zarr.open_group(str(copy), mode="r+")[DONE]
    flags[2] = 0  # sweep 0 is chunks 0-1, sweep 1 chunks 2-3, sweep 2 chunk 4
    flags[4] = 0
    code, _, err = pasim_out(capsys, "score", str(copy))
    assert code == 2 and "3 of 5 chunks written" in err
    code, _, err = pasim_out(capsys, *ARGS, "--chunk", "4", "--out", str(copy), "--resume")
    assert code == 0, err
    assert "2 of 5 chunks" in err
    a, b = _open(copy), _open(volume[0])
    for name in sweep_names(b):
        np.testing.assert_array_equal(a[name]["DBZH"].values, b[name]["DBZH"].values)


def test_each_cut_is_scored_against_the_truth_at_its_elevation(volume):
    """The example's volume truth: the 3.4 deg cut is scored against the file's 3.38 deg
    sweep (nearest between sweeps), read here independently as a single-sweep truth, at the
    radial nearest each beam; the 0.5 deg cut against the 0.48 deg sweep."""
    from pasim_blocks.truth.nexrad import NexradTruth

    from pasim_graph import Chunk as C

    tree = _open(volume[0])
    for group, elevation in (("sweep_0", 0.5), ("sweep_2", 3.4)):
        block = NexradTruth(name="truth", elevation_deg=elevation)
        single = block.process({}, C(beams=np.arange(0), resource=block.load()))["truth"]
        ds = tree[group].to_dataset()
        radials = single["azimuth"].values
        rows = [
            int(np.argmin(np.abs((radials - a + 180) % 360 - 180))) for a in ds["azimuth"].values
        ]
        n = min(ds.sizes["range"], single.sizes["gate"])
        np.testing.assert_allclose(ds["range"].values[:n], single["range"].values[:n])
        expected = single["DBZH"].values[rows, :n]
        stored = ds["truth_DBZH"].values[:, :n]
        both = np.isfinite(expected) & np.isfinite(stored)
        assert both.sum() > 200, group
        np.testing.assert_allclose(stored[both], expected[both], atol=0.01, err_msg=group)
