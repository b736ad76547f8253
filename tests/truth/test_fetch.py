"""``pasim fetch RADAR TIME``: the volume nearest a time, through the same code path as the
public archive, against a local stand-in with the archive's key layout
(``YYYY/MM/DD/SITE/SITEYYYYMMDD_HHMMSS_V06``; ``PASIM_NEXRAD_ARCHIVE`` points at it)."""

from __future__ import annotations

import shutil

import pytest

from ..conftest import ROOT, pasim_out

BUNDLED = ROOT / "blocks" / "data" / "KLBB20160601_150025_V06"


@pytest.fixture
def archive(tmp_path, monkeypatch):
    root = tmp_path / "archive"
    day = root / "2013" / "05" / "20" / "KTLX"
    day.mkdir(parents=True)
    for hms in ("195732", "200158", "200627", "201056"):
        (day / f"KTLX20130520_{hms}_V06").write_bytes(b"AR2V0006." + hms.encode())
    (day / "KTLX20130520_200627_V06_MDM").write_bytes(b"metadata, not a volume")
    before = root / "2013" / "05" / "19" / "KTLX"
    before.mkdir(parents=True)
    (before / "KTLX20130519_235800_V06.gz").write_bytes(b"old")
    klbb = root / "2016" / "06" / "01" / "KLBB"
    klbb.mkdir(parents=True)
    shutil.copyfile(BUNDLED, klbb / BUNDLED.name)
    monkeypatch.setenv("PASIM_NEXRAD_ARCHIVE", str(root))
    return root


def test_the_nearest_volume_is_fetched_and_cached(archive, tmp_path, capsys):
    cache = tmp_path / "cache"
    code, out, err = pasim_out(capsys, "fetch", "KTLX", "2013-05-20T20:08Z", "--cache", str(cache))
    assert code == 0, err
    path = out.strip()
    # 20:06:27 is 1.5 min away, 20:10:56 is 2.9 min: the nearest, not the next
    assert path == str(cache / "2013/05/20/KTLX/KTLX20130520_200627_V06")
    assert open(path, "rb").read() == b"AR2V0006.200627"
    # cached: the archive is not asked for the bytes again
    (archive / "2013/05/20/KTLX/KTLX20130520_200627_V06").write_bytes(b"changed")
    code, again, _ = pasim_out(capsys, "fetch", "ktlx", "2013-05-20 20:07", "--cache", str(cache))
    assert code == 0 and again.strip() == path and open(path, "rb").read() == b"AR2V0006.200627"
    assert not list(cache.rglob("*.partial"))


def test_near_midnight_the_day_before_is_searched(archive, tmp_path, capsys):
    code, out, err = pasim_out(
        capsys, "fetch", "KTLX", "2013-05-20T00:01Z", "--cache", str(tmp_path)
    )
    assert code == 0, err
    assert out.strip().endswith("2013/05/19/KTLX/KTLX20130519_235800_V06.gz")


def test_a_fetched_volume_runs_as_truth(archive, tmp_path, capsys):
    code, out, err = pasim_out(
        capsys, "fetch", "KLBB", "2016-06-01T15:00Z", "--cache", str(tmp_path)
    )
    assert code == 0, err
    args = ["run", str(ROOT / "graphs" / "generic_radar.yaml"), "--truth", out.strip()]
    args += ["--sector", "282:284", "--set", "scan.pulses=8", "--out", str(tmp_path / "s")]
    code, _, err = pasim_out(capsys, *args)
    assert code == 0, err


@pytest.mark.parametrize(
    ("radar", "time", "said"),
    [
        ("KTLX", "2013-05-23T12:00Z", "holds no Level-II volume of KTLX within a day"),
        ("KTLX", "2013-05-20T23:00Z", "no KTLX volume within 30 min"),
        ("KTLX", "yesterday", "expected a UTC time"),
        ("TLX", "2013-05-20T20:08Z", "four-letter radar identifier"),
    ],
)
def test_no_volume_or_a_bad_request_is_named(archive, tmp_path, capsys, radar, time, said):
    code, _, err = pasim_out(capsys, "fetch", radar, time, "--cache", str(tmp_path))
    assert code == 2 and said in err and "Traceback" not in err, err
    assert f"fetch {radar} {time}" in err


def test_an_unreachable_archive_is_named(tmp_path, capsys, monkeypatch):
    """No network: an archive nothing answers at (a closed local port) ends in one line."""
    monkeypatch.setenv("PASIM_NEXRAD_ARCHIVE", "ftp://127.0.0.1:1/nexrad")
    code, _, err = pasim_out(capsys, "fetch", "KTLX", "2013-05-20T20:08Z", "--cache", str(tmp_path))
    assert code == 2 and "ftp://127.0.0.1:1/nexrad" in err and "unreachable" in err, err
