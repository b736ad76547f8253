"""A radar file whose header times are absurd, given as the truth (issue #34).

The samples of tests/fixtures/truth (IRIS/Sigmet, Rainbow, UF) and the bundled KLBB sweep
written as CfRadial 1 are copied with their header's dates changed where the format keeps
them (IRIS: the sweep start time of each data header; Rainbow: the XML header's dates; UF:
the year of each record; CfRadial: `time_coverage_end`). A start in 1900 or 2200, or an end
before the start, was read as it stood, and the run's beams dated from it; now it is refused
in one line naming the file and the field. Furuno shares the same check (the times xradar
reads from any format) but has no sample to damage.
"""

from __future__ import annotations

import gzip
import re
import struct

import numpy as np
import pytest

from ..conftest import FIXTURES, GRAPHS, pasim_out
from .test_radar_files import cfradial_from_level2
from .test_truth_sanity import damaged, refusal

GENERIC = str(GRAPHS / "generic_radar.yaml")
TRUTH = FIXTURES / "truth"
IRIS = TRUTH / "SUR210819000227_40rays_300gates.RAWKPJV"
RAINBOW = TRUTH / "2013051000000600dBZ.vol"
UF = TRUTH / "MC3E_NPOL_2011_0524_2356_hid_300gates.uf.gz"


@pytest.fixture(scope="module")
def klbb(tmp_path_factory):
    """The KLBB truth sweep and the same sweep as a CfRadial 1 file (read-only: copy it)."""
    return cfradial_from_level2(tmp_path_factory.mktemp("klbb"))


def iris_in_year(tmp_path, year: int):
    """The IRIS sample with the year of every data header's sweep start time set."""
    data = bytearray(IRIS.read_bytes())
    record, first = 6144, 6144 * 2 + 12  # the first sweep's data headers, 76 bytes each
    n = 0
    while struct.unpack_from("<h", data, first + 76 * n)[0] == 24:  # ingest_data_header
        struct.pack_into("<h", data, first + 76 * n + 18, year)  # its start time's year
        n += 1
    assert n == 12 and len(data) % record == 0
    path = tmp_path / f"iris{year}.RAWKPJV"
    path.write_bytes(bytes(data))
    return path


def uf_in_year(tmp_path, year: int):
    """The UF sample with the year (word 26 of the mandatory header) of every record set."""
    data = bytearray(gzip.decompress(UF.read_bytes()))
    starts = [m.start() for m in re.finditer(b"UF", data)]
    pos, n = starts[0], 0
    while pos < len(data) and data[pos : pos + 2] == b"UF":
        struct.pack_into(">h", data, pos + 50, year)
        pos += 2 * struct.unpack_from(">h", data, pos + 2)[0] + 8  # record and its marks
        n += 1
    assert n > 100
    path = tmp_path / f"uf{year}.uf"
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("year", [1900, 2200])
def test_an_iris_file_dated_out_of_bounds_is_refused_naming_the_field(tmp_path, year):
    message = refusal(iris_in_year(tmp_path, year))
    assert f"`time_coverage_start` is {year}-08-19T00:02:31Z, not between 1940 and 2100" in (
        message
    )


def test_a_rainbow_file_dated_1900_is_refused_naming_the_field(tmp_path):
    path = tmp_path / "rainbow1900.vol"
    path.write_bytes(RAINBOW.read_bytes().replace(b"2013-05-10", b"1900-05-10"))
    assert "`time_coverage_start` is 1900-05-10T00:00:06Z, not between" in refusal(path)


def test_a_uf_file_dated_2200_is_refused_naming_the_field(tmp_path):
    """The UF sample holds RHIs: read as a volume's truth, its time is checked there too."""
    from pasim_blocks.truth.radar_files import open_radar_file
    from pasim_blocks.truth.rhi_files import rhi_sweeps

    path = uf_in_year(tmp_path, 2200)
    tree, kind = open_radar_file(path)
    with pytest.raises(ValueError) as info:
        rhi_sweeps(tree, kind, path, lambda angles: angles[:1])
    assert str(path) in str(info.value)
    assert "`time_coverage_start` is 2200-05-24T23:56:01Z, not between" in str(info.value)


def end_at(text: str):
    """Set ``time_coverage_end`` of a CfRadial copy to ``text`` (a character array)."""

    def change(nc):
        nc.renameVariable("time_coverage_end", "time_coverage_end_string")
        nc.createDimension("end_length", 32)
        var = nc.createVariable("time_coverage_end", "S1", ("end_length",))
        var[:] = np.frombuffer(text.encode().ljust(32, b"\0"), "S1")

    return change


def test_an_end_before_the_start_is_refused_and_a_run_writes_nothing(klbb, tmp_path, capsys):
    path = damaged(klbb, tmp_path, end_at("2016-06-01T14:00:00Z"))
    message = refusal(path)
    assert "`time_coverage_end` 2016-06-01T14:00:00Z is before `time_coverage_start`" in message
    out = tmp_path / "s.zarr"
    code, _, err = pasim_out(
        capsys, "run", GENERIC, "--truth", str(path), "--sector", "280:281", "--out", str(out)
    )
    lines = [line for line in err.splitlines() if line.startswith("error")]
    assert code == 2 and "Traceback" not in err, err
    assert len(lines) == 1 and str(path) in lines[0] and "`time_coverage_end`" in lines[0]
    assert not out.exists()


def test_the_samples_as_they_are_still_read():
    from pathlib import Path

    from pasim_blocks.truth.radar_files import read_radar_sweep

    for path, start in ((IRIS, "2021-08-19T00:02:31Z"), (RAINBOW, "2013-05-10T00:00:06Z")):
        assert read_radar_sweep(Path(path), 0.5).site["time_coverage_start"] == start
