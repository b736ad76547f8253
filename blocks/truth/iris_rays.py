"""IRIS/Sigmet rays kept with their own azimuth: a correction of xradar's IRIS reader.

An IRIS RAW sweep stores its rays in time order, each moment of a ray as a 6-word header
(start and end azimuth and elevation as binary angles, the number of bins, the time
offset) followed by that ray's data; the header describes the data it precedes. xradar
(0.12 and before) reads the first moment a sweep is asked for through
``IrisRawFile._get_ray_record_offsets_and_data``, which starts its row counter at -1: the
sweep's first ray lands in the last row and every other ray one row early. The azimuth,
elevation and time of the sweep are decoded from that same rotated buffer (the headers of
the first moment, ``DB_XHDR`` where the file has it) while every later moment is read in
order, so each data row is labelled with the next ray's azimuth: the truth came out one
radial (about 1 deg on a 360-ray sweep) clockwise of where the radar looked. Py-ART's
``read_sigmet`` pairs them as the file does. Upstream: openradar/xradar issue #357, fixed
by pull request #375 (the counter starts at 0).

The correction here is the smallest that restores the file's pairing: the rotated buffer
is rolled back one row, on an xradar whose method is found, by a probe, to rotate; on one
that reads in order (a release with the fix) nothing is changed.
"""

from __future__ import annotations

import threading
from types import SimpleNamespace
from typing import Any

import numpy as np

_LOCK = threading.Lock()
_STATE: dict[str, str] = {}


class _Probe:
    """Stands in for an ``IrisRawFile`` of one sweep of three rays of one moment, each ray
    numbered 1, 2, 3 in its first data word, so the method's row order can be seen."""

    def __init__(self) -> None:
        self.data = {
            1: {
                "ingest_data_hdrs": {"DB_DBZ2": {"number_rays_file_expected": 3}},
                "record_number": 0,
                "first_ray_byte_offset": 0,
            }
        }
        self._product_hdr = {"product_end": {"number_bins": 1}}
        self.rh = SimpleNamespace(pos=0)
        self.rays_read = 0

    def init_record(self, recnum: int) -> None:
        pass

    def get_ray(self, data: np.ndarray, skip: bool = False) -> tuple[int, int]:
        self.rays_read += 1
        if not skip:
            data[6] = self.rays_read
        return 0, self.rays_read


def rows_as_read(method: Any) -> list[int]:
    """The ray (1, 2, 3 in file order) each row holds after ``method`` reads a sweep of
    three rays into a fresh buffer: ``[1, 2, 3]`` in order, ``[2, 3, 1]`` rotated."""
    rows = np.zeros((3, 7), np.int16)
    method(_Probe(), 1, rows, idx=0)
    return [int(v) for v in rows[:, 6]]


def keep_iris_rays_in_order() -> str:
    """Make xradar's IRIS reader keep each ray with its own header; returns what was found:
    ``"in order"`` (nothing changed), ``"corrected"`` (the rotation is undone) or
    ``"unknown"`` (the method could not be probed; left as it is, and
    ``tests/truth/test_iris_azimuth.py`` tells whether it pairs rays rightly). Idempotent."""
    with _LOCK:
        if "state" in _STATE:
            return _STATE["state"]
        from xradar.io.backends import iris

        original = iris.IrisRawFile._get_ray_record_offsets_and_data
        try:
            found = rows_as_read(original)
        except Exception:
            found = []
        if found == [1, 2, 3]:
            state = "in order"
        elif found == [2, 3, 1]:

            def in_file_order(
                self: Any, sweep_number: int, raw_data: np.ndarray, idx: int | None = None
            ) -> None:
                original(self, sweep_number, raw_data, idx=idx)
                if idx is not None:  # only a read that fills raw_data rotates it
                    raw_data[:] = np.roll(raw_data, 1, axis=0)

            in_file_order.__wrapped__ = original  # type: ignore[attr-defined]
            iris.IrisRawFile._get_ray_record_offsets_and_data = in_file_order
            state = "corrected"
        else:
            state = "unknown"
        _STATE["state"] = state
        return state


__all__ = ["keep_iris_rays_in_order", "rows_as_read"]
