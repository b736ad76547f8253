"""``measure_beams`` (``blocks/antennas/beam_figures.py``): an antenna measured at a list of
absolute beam directions, as ``pasim pattern --scan`` measures a scan's beams.

Compared against :func:`measure` of the same antenna steered by hand to each direction's
offset from broadside (the same figures to the bit), on a small planar face turned to 290 deg.
"""

from __future__ import annotations

import pytest
from pasim_blocks.antennas.beam_figures import measure, measure_beams, steer_from_broadside
from pasim_blocks.antennas.planar import PlanarPatchArray


def test_each_direction_is_measured_as_steering_it_by_hand() -> None:
    block = PlanarPatchArray(name="a", n_x=16, n_y=16, face_azimuth_deg=290.0)
    beams = [(290.0, 0.0), (260.0, 5.0)]
    rows = measure_beams(block, beams, seed=1, span_deg=30.0)
    assert [(r["azimuth_deg"], r["elevation_deg"]) for r in rows] == beams
    assert [r["steer_deg"] for r in rows] == [[0.0, 0.0], [-30.0, 5.0]]
    for (az, el), row in zip(beams, rows, strict=True):
        steer = steer_from_broadside(block, az, el)
        by_hand = measure(block, *steer, seed=1, resource=block.load(), span_deg=30.0)
        del by_hand["cuts"]
        assert {k: row[k] for k in by_hand} == by_hand
        assert "cuts" not in row
        assert row["beam_azimuth_deg"] == pytest.approx(az) and row["beam_elevation_deg"] == el
    # Steered 30 deg off broadside the beam widens.
    assert rows[1]["beamwidth_az_deg"] > rows[0]["beamwidth_az_deg"]


def test_no_direction_measures_nothing() -> None:
    assert measure_beams(PlanarPatchArray(name="a", n_x=4, n_y=4), []) == []
