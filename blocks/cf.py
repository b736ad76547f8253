"""CF/Radial attributes (names, units, standard names) from xradar's data model, kept as data.

xradar takes over half a second to import, more than the rest of a one-beam run's set-up. Its
dictionaries are therefore read from a snapshot (``data/cf_attributes.json``, written by
``python -m pasim_blocks.cf``) made with the xradar version it names; with another xradar
installed they are taken from xradar itself. ``tests/store/test_cf.py`` checks the snapshot against
the installed xradar. Blocks fetch the dictionaries once, when they are built in the client,
and carry them as plain data to wherever their chunks run.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import Any

SNAPSHOT = Path(__file__).parent / "data" / "cf_attributes.json"


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
    """The attributes: from the snapshot when it was made with the installed xradar."""
    try:
        saved = json.loads(SNAPSHOT.read_text())
    except (OSError, ValueError):
        saved = {}
    if saved.get("xradar") == version("xradar"):
        return CFAttributes(**saved["attributes"])
    return from_xradar()


def from_xradar() -> CFAttributes:
    """The attributes as the installed xradar's data model gives them."""
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


def write_snapshot(path: Path = SNAPSHOT) -> None:
    """Write the installed xradar's attributes to the snapshot ``cf_attributes`` reads."""
    data = {"xradar": version("xradar"), "attributes": dataclasses.asdict(from_xradar())}
    path.write_text(json.dumps(data, indent=1) + "\n")


if __name__ == "__main__":
    write_snapshot()
    print(f"wrote {SNAPSHOT}")
