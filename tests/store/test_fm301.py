"""The FM-301 / CfRadial 2 vocabulary (``pasim_graph/fm301.py``) against an independent
source, xradar's data model (``xradar.model``, which follows the CfRadial 2.1 / FM-301
document), and the store's use of it."""

from __future__ import annotations

import numpy as np
import xarray as xr

from pasim_graph import fm301
from pasim_graph.store import split_volume


def test_root_variables_are_fm301s_and_cover_what_it_requires() -> None:
    """Every variable the store moves to the root is a root variable of xradar's model, and
    every root variable the model requires is one of them, or one the store writes over the
    volume's sweeps (``sweep_group_name``, ``sweep_fixed_angle``: store.layout.volume_sweeps)."""
    import xradar.model as xm

    ours = {*fm301.SITE_VARIABLES, *fm301.ROOT_VARIABLES}
    assert ours <= set(xm.required_root_vars) | set(xm.optional_root_vars)
    assert set(xm.required_root_vars) - ours == {"sweep_group_name", "sweep_fixed_angle"}


def test_the_scans_beams_carry_every_sweep_variable_fm301_requires() -> None:
    """The beams port (every scan's output) declares each sweep-group variable xradar's model
    requires (sweep number and mode, follow and PRT mode, fixed angle, the beams' angles)."""
    import xradar.model as xm
    from pasim_blocks.signals import BEAMS

    assert set(xm.required_sweep_metadata_vars) <= set(BEAMS.schema.variables)


def test_time_attributes_are_xradars() -> None:
    """The beams' time carries the standard name xradar's model gives time."""
    import xradar.model as xm

    assert fm301.TIME_ATTRS["standard_name"] == xm.time_attrs["standard_name"]


def test_an_rhi_mode_is_fm301s_rhi_or_manual_rhi_in_any_case() -> None:
    """``rhi_mode`` reads a mode from another tool's file: FM-301's ``rhi`` and
    ``manual_rhi``, as some write them in capitals; no PPI mode."""
    assert fm301.rhi_mode(fm301.SWEEP_MODE_RHI)
    assert all(fm301.rhi_mode(m) for m in ("manual_rhi", "RHI", "Manual_RHI"))
    modes = (fm301.SWEEP_MODE_PPI, fm301.SWEEP_MODE_STEERED, "manual_ppi", "sector", "")
    assert not any(fm301.rhi_mode(m) for m in modes)


def test_sweep_names_are_in_sweep_order_not_text_order() -> None:
    """sweep_10 follows sweep_9 (text order would put it after sweep_1); other groups are
    not sweeps."""
    order = [3, 10, 0, 1, 9, 2, 4, 5, 6, 7, 8, 11]
    tree = xr.DataTree.from_dict(
        {
            "/": xr.Dataset(),
            **{f"/{fm301.sweep_group(k)}": xr.Dataset() for k in order},
            "/radar_parameters": xr.Dataset(),
        }
    )
    assert fm301.sweep_names(tree) == [f"sweep_{k}" for k in range(12)]


def test_the_store_moves_site_and_volume_variables_to_the_root() -> None:
    """split_volume: the site and the volume's variables go to the root, the sweep keeps the
    rest; an RHI's beams run along elevation, a PPI's along azimuth (FM-301)."""
    for mode, dim in ((fm301.SWEEP_MODE_RHI, "elevation"), (fm301.SWEEP_MODE_PPI, "azimuth")):
        sweep = xr.Dataset(
            {
                "DBZH": (("beam", "range"), np.zeros((2, 3), np.float32)),
                "sweep_mode": ((), mode),
                "time_coverage_start": ((), "2000-01-01T00:00:00Z"),
                "time_coverage_end": ((), "2000-01-01T00:00:01Z"),
                "volume_number": ((), 0),
                "platform_type": ((), fm301.PLATFORM_FIXED),
                "instrument_type": ((), fm301.INSTRUMENT_RADAR),
            },
            coords={
                "azimuth": ("beam", [1.0, 2.0]),
                "elevation": ("beam", [0.5, 1.5]),
                **{k: ((), 0.0) for k in fm301.SITE_VARIABLES},
            },
        )
        root, out = split_volume(sweep, {})
        assert set(root.variables) == {*fm301.SITE_VARIABLES, *fm301.ROOT_VARIABLES}
        assert not set(fm301.ROOT_VARIABLES) & set(out.variables)
        assert out["DBZH"].dims == (dim, "range")
        assert "platform_is_mobile" not in root.attrs
