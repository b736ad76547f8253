"""CF/Radial attributes (names, units, standard names) from xradar's data model, kept as data.

xradar takes over a second to import. Blocks fetch these dictionaries once, when they are
built in the client, and carry them as plain data to wherever their chunks run, so that
workers never import xradar.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class CFAttributes:
    sweep_vars: dict[str, dict[str, Any]]
    range: dict[str, Any]
    azimuth: dict[str, Any]
    elevation: dict[str, Any]
    latitude: dict[str, Any]
    longitude: dict[str, Any]
    altitude: dict[str, Any]
    nyquist_velocity: dict[str, Any]

    def var(self, name: str) -> dict[str, Any]:
        """A copy of a moment's attributes (empty for names xradar does not know)."""
        return dict(self.sweep_vars.get(name, {}))


@functools.lru_cache(maxsize=1)
def cf_attributes() -> CFAttributes:
    import xradar.model as xm

    return CFAttributes(
        sweep_vars={k: dict(v) for k, v in xm.sweep_vars_mapping.items()},
        range=dict(xm.get_range_attrs()),
        azimuth=dict(xm.get_azimuth_attrs()),
        elevation=dict(xm.get_elevation_attrs()),
        latitude=dict(xm.get_latitude_attrs()),
        longitude=dict(xm.get_longitude_attrs()),
        altitude=dict(xm.get_altitude_attrs()),
        nyquist_velocity=dict(xm.get_nyquist_velocity_attrs()),
    )
