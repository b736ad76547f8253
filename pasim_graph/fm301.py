"""The FM-301 / CfRadial 2 vocabulary, in one place (as xradar keeps its data model in one
``model.py``): the names of the moments and their units, the CF attributes of the moments and
coordinates, the dimensions a sweep's beams run along, the site and volume variables of the
root group, the sweep groups' names and the words FM-301 gives sweep and PRT modes.

The engine writes and reads stores with these names and the block library builds its ports and
outputs from them (importing downward); no module keeps its own copy.

CF attributes from xradar's data model are kept as data: xradar takes over half a second to
import, more than the rest of a one-beam run's set-up. Its dictionaries are therefore read from
a snapshot (``data/cf_attributes.json``, written by ``python -m pasim_graph.fm301``) made with
the xradar version it names; with another xradar installed they are taken from xradar itself.
``tests/store/test_cf.py`` checks the snapshot against the installed xradar. Blocks fetch the
dictionaries once, when they are built in the client, and carry them as plain data to wherever
their chunks run.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import xarray as xr

#: Units of the six moments, as the truth and the estimates carry them (CF/UDUNITS strings).
MOMENT_UNITS = {
    "DBZH": "dBZ",
    "ZDR": "dB",
    "RHOHV": "1",
    "PHIDP": "degrees",
    "VRADH": "m s-1",
    "WRADH": "m s-1",
}
#: What each moment is, in the words of the ports that carry it.
MOMENT_DOCS = {
    "DBZH": "reflectivity factor, H",
    "ZDR": "differential reflectivity",
    "RHOHV": "co-polar correlation coefficient",
    "PHIDP": "differential phase",
    "VRADH": "radial velocity, positive away",
    "WRADH": "Doppler spectrum width",
}
#: The moments a pulse-pair processor estimates, CfRadial names.
MOMENT_FIELDS = tuple(MOMENT_UNITS)
#: The moments only a dual-polarisation radar measures.
POLARIMETRIC_FIELDS = ("ZDR", "RHOHV", "PHIDP")

#: The dimensions a stored sweep's beams may run along, in the order they are looked for: an
#: RHI's along elevation, every other sweep's along azimuth, a beam list's along time.
BEAM_DIMENSIONS = ("azimuth", "elevation", "time")
#: The site's coordinates, which FM-301 keeps at the root of a volume.
SITE_VARIABLES = ("latitude", "longitude", "altitude")
#: The volume's variables, which FM-301 keeps at the root (a scan emits them with its beams).
ROOT_VARIABLES = (
    "time_coverage_start",
    "time_coverage_end",
    "volume_number",
    "platform_type",
    "instrument_type",
)

#: FM-301 sweep modes of the scans: a PPI sector, an RHI, an electronically steered beam list.
SWEEP_MODE_PPI = "azimuth_surveillance"
SWEEP_MODE_RHI = "rhi"
SWEEP_MODE_STEERED = "electronic_steering"
#: FM-301 PRT modes: one PRT, two alternating pulse to pulse (staggered), two by dwell (dual).
PRT_MODE_FIXED = "fixed"
PRT_MODE_STAGGERED = "staggered"
PRT_MODE_DUAL = "dual"
#: FM-301 follow mode of a radar that follows no target (a ground radar).
FOLLOW_MODE_NONE = "none"
#: FM-301 platform and instrument type of a radar on the ground.
PLATFORM_FIXED = "fixed"
INSTRUMENT_RADAR = "radar"

#: Attributes of the sweep variables the scans emit that xradar's model does not give.
PRT_ATTRS = {"units": "seconds", "long_name": "pulse repetition time"}
PULSES_ATTRS = {"long_name": "pulses per dwell"}
TIME_ATTRS = {"standard_name": "time"}
#: Attributes of the root's ``sweep_group_name`` (the groups of a volume's sweeps, in order).
SWEEP_GROUP_NAME_ATTRS = {"long_name": "name of the group holding each sweep"}


def rhi_mode(mode: str) -> bool:
    """A sweep mode read from a radar file names an RHI: FM-301's ``rhi`` or ``manual_rhi``,
    in any case (the scans here write :data:`SWEEP_MODE_RHI`)."""
    return SWEEP_MODE_RHI in mode.lower()


def sweep_group(index: int) -> str:
    """The FM-301 group of the sweep at ``index``."""
    return f"sweep_{index}"


def sweep_names(tree: xr.DataTree) -> list[str]:
    """The FM-301 sweep groups of a volume, in order (``sweep_0``, ``sweep_1``, ...)."""
    names = [str(n) for n in tree.children if str(n).startswith("sweep_")]
    return sorted(names, key=lambda n: int(n.split("_", 1)[1]) if n[6:].isdigit() else 1 << 30)


#: xradar's data model as the installed xradar gave it (:func:`write_snapshot`).
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
