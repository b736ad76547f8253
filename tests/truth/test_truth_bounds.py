"""Size bounds on truth and schedule files, checked from what a file declares before any of
its data is read: each hostile file, small on disk, is refused by the reader in a fresh
interpreter within 2 s and with the process's peak resident memory under 300 MB (its imports
included: about 170 MB).

Before the bounds: an ODIM_H5 file of 72 kB declaring ``nbins`` = 1e9 took 13.9 GB; a 1000^3
gridded truth of zeros (a few kB as netCDF-4: no chunk is written) 8 GB, and ran; a schedule
of 4 million rows 2.9 GB.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from ..conftest import FIXTURES

ODIM = FIXTURES / "truth" / "T_PAZD63_C_LFPW_20230420065331.h5"

#: The refusal's bounds: CPU seconds of the call (not wall time: on a loaded machine the wall
#: clock measures the other processes; reading the billion gates would take minutes of CPU)
#: and the peak resident memory.
SECONDS, MEGABYTES = 2.0, 300.0

MEASURE = """
import json, sys, time
{imports}
start, cpu_start = time.perf_counter(), time.process_time()
try:
    {call}
    message = "read"
except ValueError as exc:
    message = str(exc)
seconds, cpu = time.perf_counter() - start, time.process_time() - cpu_start
# VmHWM, the peak resident memory of this process's own address space: ru_maxrss would
# carry over the parent's peak across fork and exec (a large pytest process's)
status = open("/proc/self/status").read()
peak = int(status.split("VmHWM:")[1].split()[0]) / 1024
print(json.dumps({{"seconds": seconds, "cpu_s": cpu, "peak_mb": peak, "message": message}}))
"""


def measured(imports: str, call: str) -> dict:
    """Run ``call`` after ``imports`` in a fresh interpreter, under a 4 GiB address-space
    limit (a regression fails instead of taking the machine): wall and CPU seconds of the call, the
    process's peak resident memory (MB, VmHWM; imports included), and the refusal's
    message."""
    limit = "import resource; resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))\n"
    code = MEASURE.format(imports=limit + imports, call=call)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    print(result)  # the measured numbers, with pytest -s
    return result


def refused_quickly(result: dict, *words: str) -> None:
    assert result["message"] != "read", result
    for word in words:
        assert word in result["message"], result
    assert "\n" not in result["message"]
    assert result["cpu_s"] < SECONDS, result
    assert result["peak_mb"] < MEGABYTES, result


def test_an_odim_file_declaring_a_billion_gates_is_refused_before_reading(tmp_path):
    import h5py

    path = tmp_path / "nbins.h5"
    shutil.copyfile(ODIM, path)
    with h5py.File(path, "r+") as f:
        f["dataset1/where"].attrs["nbins"] = np.int64(1_000_000_000)
    assert path.stat().st_size < 100_000
    result = measured(
        "from pasim_blocks.truth.radar_files import read_radar_sweep",
        f"read_radar_sweep({str(path)!r}, 1.0)",
    )
    refused_quickly(result, str(path), "dataset1/where", "1,000,000,000 gates", "before reading")


def test_a_gridded_truth_of_a_billion_points_is_refused_before_reading(tmp_path):
    import netCDF4

    path = tmp_path / "grid.nc"
    with netCDF4.Dataset(path, "w") as nc:
        for name in ("z", "y", "x"):
            nc.createDimension(name, 1000)
            nc.createVariable(name, "f4", (name,))[:] = np.arange(1000) * 500.0
        # 1000^3 zeros: the fill value, no chunk written (the file is a few kB)
        nc.createVariable("DBZH", "f4", ("z", "y", "x"), zlib=True, fill_value=0.0)
    assert path.stat().st_size < 100_000
    warm = tmp_path / "warm.nc"
    with netCDF4.Dataset(warm, "w") as nc:
        nc.createDimension("x", 2)
        nc.createVariable("x", "f4", ("x",))[:] = [0.0, 1.0]  # an index: dask's, pint's imports
    result = measured(
        # xarray imports its backends and their accessors (xradar's, pint's; about 2 s here)
        # at its first open: imports, not the refusal, so before the clock starts
        f"import xarray\nxarray.open_dataset({str(warm)!r}).close()\n"
        "from pasim_blocks.truth.grid import open_grid",
        f"open_grid({str(path)!r})",
    )
    refused_quickly(result, "grid.nc", "DBZH declares 1000 x 1000 x 1000", "before reading")


def test_a_schedule_of_ten_million_rows_is_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.csv"
    row = b"300,0.5,16,0.003\n"
    with path.open("wb") as f:
        f.write(b"azimuth_deg,elevation_deg,pulses,prt_s\n")
        for _ in range(100):
            f.write(row * 100_000)
    result = measured(
        "from pasim_blocks.scans.schedule import read_schedule",
        f"_, problems = read_schedule({str(path)!r})\n    raise ValueError(problems[0])",
    )
    refused_quickly(result, str(path), "more than 1,000,000 lines", "before reading")


@pytest.mark.parametrize("rays, gates", [(360, 40_000), (30_000, 500)])
def test_sweep_bounds(rays, gates):
    from pasim_blocks.truth.sizes import SizeError, check_sweep

    with pytest.raises(SizeError, match=r"^x.h5: declares"):
        check_sweep("x.h5", rays, gates)
    check_sweep("x.h5", 7200, 16_000)  # a 0.05 deg sweep of 16,000 gates is read


def test_a_cfradial2_store_declaring_a_billion_gates_is_refused_before_opening(tmp_path):
    # xarray reads an index coordinate whole when it opens a store: the store's `range` of
    # 1e9 gates took 7.9 GB and 140 s before it was refused by the sweep's bound.
    import zarr

    path = tmp_path / "big.zarr"
    root = zarr.open_group(path, mode="w", zarr_format=3)
    sweep = root.create_group("sweep_0")
    n = 1_000_000_000
    sweep.create_array(
        "DBZH", shape=(360, n), chunks=(360, 1 << 20), dtype="f4",
        dimension_names=("azimuth", "range"),
    )  # fmt: skip
    sweep.create_array(
        "range", shape=(n,), chunks=(1 << 20,), dtype="f4", dimension_names=("range",)
    )
    sweep.create_array("azimuth", shape=(360,), dtype="f8", dimension_names=("azimuth",))[:] = (
        np.arange(360.0)
    )
    result = measured(
        "from pasim_blocks.truth.radar_files import read_radar_sweep",
        f"read_radar_sweep({str(path)!r}, 0.5)",
    )
    refused_quickly(result, str(path), "sweep_0/DBZH", "1,000,000,000 gates", "before reading")
