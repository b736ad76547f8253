"""Damaged or impossible radar files other than Level-II, given as the truth.

Each test takes a real file (the bundled KLBB sweep written as CfRadial 1 by xradar, or a
sample of tests/fixtures), damages one variable of a copy in ``tmp_path`` with netCDF4 or
h5py, and checks that the truth is refused in one line naming the file and the variable
(exit 2 from the command line), where it used to be read wrong or fail in numpy's words.
"""

from __future__ import annotations

import numpy as np
import pytest

from ..conftest import GRAPHS, pasim_out
from .test_radar_files import cfradial_from_level2

GENERIC = str(GRAPHS / "generic_radar.yaml")


@pytest.fixture(scope="module")
def klbb(tmp_path_factory):
    """The KLBB truth sweep and the same sweep as a CfRadial 1 file (read-only: copy it)."""
    return cfradial_from_level2(tmp_path_factory.mktemp("klbb"))


def damaged(klbb, tmp_path, change):
    """A copy of the KLBB CfRadial 1 file with ``change(netCDF4.Dataset)`` applied."""
    import shutil

    import netCDF4

    path = tmp_path / "damaged.nc"
    shutil.copyfile(klbb[1], path)
    with netCDF4.Dataset(path, "a") as nc:
        change(nc)
    return path


def refusal(path) -> str:
    from pasim_blocks.truth.radar_files import read_radar_sweep

    with pytest.raises(ValueError) as info:
        read_radar_sweep(path, 0.5)
    message = str(info.value)
    assert str(path) in message and "\n" not in message, message
    return message


def test_a_cfradial_file_without_its_range_is_refused_not_read_in_gate_numbers(
    klbb, tmp_path, capsys
):
    # xradar numbers the gates 0, 1, 2, ... when `range` is missing: the truth was read as if
    # its first gate were at 0 m and its 1832nd at 1831 m, with exit 0 and no note.
    path = damaged(klbb, tmp_path, lambda nc: nc.renameVariable("range", "gate_distance"))
    assert "no `range` variable" in refusal(path)
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--sector", "280:281", "--out",
        str(tmp_path / "s.zarr"),
    )  # fmt: skip
    lines = [line for line in err.splitlines() if line.startswith("error")]
    assert code == 2 and "Traceback" not in err, err
    assert len(lines) == 1 and str(path) in lines[0] and "`range`" in lines[0], err
    assert not (tmp_path / "s.zarr").exists()


@pytest.mark.parametrize(
    "variable, index, value, words",
    [
        ("azimuth", 7, 1e6 + 280.0, "`azimuth` holds 1.00028e+06 deg, not [-360, 360] (at 1 "),
        ("azimuth", 3, np.nan, "`azimuth` holds nan deg"),
        ("elevation", 5, 95.0, "`elevation` holds 95 deg, not [-90, 90]"),
        ("elevation", 0, -np.inf, "`elevation` holds -inf deg"),
        ("range", 2, np.nan, "`range` holds nan m, not finite and >= 0 (at 1 of its 1832 gates)"),
        ("range", 10, 0.0, "`range` does not increase (0 m after 4375 m at gate 10)"),
    ],
)
def test_impossible_coordinates_are_refused_naming_the_variable(
    klbb, tmp_path, variable, index, value, words
):
    def change(nc):
        nc[variable].set_auto_mask(False)
        nc[variable][index] = value

    message = refusal(damaged(klbb, tmp_path, change))
    assert words in message, message


def char_array_time(nc, text="2016-06-01T15:00:25Z"):
    """``time_coverage_start`` as Radx writes it: a character array, NUL-padded to 32."""
    nc.renameVariable("time_coverage_start", "time_coverage_start_string")
    nc.createDimension("string_length_32", 32)
    var = nc.createVariable("time_coverage_start", "S1", ("string_length_32",))
    var[:] = np.frombuffer(text.encode().ljust(32, b"\0"), "S1")


def test_a_character_array_start_time_is_read_as_text(klbb, tmp_path, capsys):
    # It was refused by the scan: Error parsing datetime string "b'2016-06-01T15:00:25Z'"
    from pasim_blocks.truth.radar_files import read_radar_sweep

    path = damaged(klbb, tmp_path, char_array_time)
    assert read_radar_sweep(path, 0.5).site["time_coverage_start"] == "2016-06-01T15:00:25Z"
    out = tmp_path / "s.zarr"
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--sector", "280:281", "--out", str(out)
    )
    assert code == 0, err
    import xarray as xr

    root = xr.open_datatree(out, engine="zarr").to_dataset()
    assert str(root["time_coverage_start"].values).startswith("2016-06-01T15:00:2"), root


def test_a_start_time_that_is_not_a_time_is_refused_by_name(klbb, tmp_path):
    path = damaged(klbb, tmp_path, lambda nc: char_array_time(nc, "not a time"))
    assert "`time_coverage_start` is 'not a time', not an ISO 8601 time" in refusal(path)


def load_truth(path, **params):
    """The truth block's load on ``path`` (what ``pasim run`` does first)."""
    from pasim_blocks.truth.nexrad import NexradTruth

    return NexradTruth(name="truth", path=str(path), **params).load()


def test_an_emptied_sweep_is_refused_naming_the_file_and_sweep(klbb, tmp_path):
    # As a volume it failed with numpy's "attempt to get argmin of an empty sequence".
    def empty(nc):
        nc["sweep_end_ray_index"][:] = nc["sweep_start_ray_index"][:] - 1

    path = damaged(klbb, tmp_path, empty)
    for sweeps in ("single", "volume"):
        with pytest.raises(ValueError) as info:
            load_truth(path, sweeps=sweeps)
        message = str(info.value)
        assert message.startswith(f"{path} (CfRadial 1), sweep_0: holds 0 rays of 1832 gates")
        assert "\n" not in message


@pytest.mark.parametrize("fraction", [0.05, 0.3, 0.6, 0.95])
def test_a_truncated_file_is_refused_in_one_line_naming_it(klbb, tmp_path, fraction):
    data = klbb[1].read_bytes()
    path = tmp_path / "truncated.nc"
    path.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(ValueError) as info:
        load_truth(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "fails, words",
    [
        (lambda: np.argmin([]), "ValueError: attempt to get argmin of an empty sequence"),
        (lambda: np.zeros(0).max(), "ValueError: zero-size array to reduction operation"),
        (lambda: 1.0 / 0.0, "ZeroDivisionError: float division by zero"),
        (lambda: np.linalg.svd(np.full((3, 3), np.nan)), "LinAlgError: SVD did not converge"),
    ],
)
def test_numpy_failures_on_a_damaged_file_name_the_file_and_sweep(fails, words):
    from pasim_blocks.truth.radar_files import damaged as named

    with pytest.raises(ValueError) as info:
        with named("x.nc (CfRadial 1), sweep_3"):
            fails()
    assert str(info.value).startswith("x.nc (CfRadial 1), sweep_3: damaged or empty, cannot be ")
    assert words in str(info.value)
    # a refusal of ours, which names the file, passes unchanged
    with pytest.raises(ValueError, match=r"^x.nc: no sweep$"):
        with named("x.nc (CfRadial 1), sweep_3"):
            raise ValueError("x.nc: no sweep")
