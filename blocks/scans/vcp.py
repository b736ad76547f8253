"""NEXRAD volume coverage patterns as lists of cuts, and the text form of a cut list.

Where the numbers come from:

- Elevation angles: the WSR-88D's published VCP tables (Radar Operations Center; NWS
  Warning Decision Training Division, DLOC "VCP Characteristics"): VCP 212 scans the 14
  angles of VCP 12, VCP 215 scans 15 angles, both from 0.5 to 19.5 deg, with split cuts
  (a long-PRT surveillance rotation then a short-PRT Doppler rotation at the same angle) at
  the three lowest.
- PRF numbers and pulses per radial: written from memory of those tables, not copied from
  them: they are approximate (a few pulses either way). Batch cuts (surveillance and
  Doppler pulses interleaved in one radial) are modelled by their Doppler pulses alone.
- PRF number to rate: the WSR-88D's eight PRFs (delta PRI 2), also from memory.

Check them against the ROC's VCP documentation before relying on them; a graph that needs
exact numbers gives its own ``cuts``. The durations these presets give (sum of the dwells
over 360 deg) are in docs/scans.md beside the published volume times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: WSR-88D PRF number -> pulse repetition frequency (Hz), delta PRI 2 (from memory).
PRF_HZ = {1: 322.0, 2: 446.0, 3: 644.0, 4: 857.0, 5: 1014.0, 6: 1095.0, 7: 1181.0, 8: 1282.0}


@dataclass(frozen=True)
class Cut:
    """One rotation of a volume: elevation, PRT, pulses per dwell, and optionally its own
    azimuth sector (else the scan's)."""

    elevation_deg: float
    prt_s: float
    pulses: int
    sector: tuple[float, float] | None = None

    def text(self) -> str:
        sector = f" {self.sector[0]:g}:{self.sector[1]:g}" if self.sector else ""
        return f"{self.elevation_deg:g} {self.prt_s:.6g} {self.pulses}{sector}"


def _cuts(rows: list[tuple[float, int, int]]) -> tuple[Cut, ...]:
    return tuple(Cut(el, 1.0 / PRF_HZ[prf], pulses) for el, prf, pulses in rows)


# (elevation deg, PRF number, pulses per radial); split cuts appear twice: CS then CD.
_VCP212 = [
    (0.5, 1, 15), (0.5, 7, 64),  # SZ-2 split cut
    (0.9, 1, 15), (0.9, 7, 64),  # SZ-2 split cut
    (1.3, 1, 15), (1.3, 7, 64),  # SZ-2 split cut
    (1.8, 5, 40), (2.4, 5, 40), (3.1, 5, 40), (4.0, 5, 40),  # batch (Doppler pulses)
    (5.1, 7, 44), (6.4, 7, 44), (8.0, 8, 44), (10.0, 8, 44),  # contiguous Doppler
    (12.5, 8, 44), (15.6, 8, 44), (19.5, 8, 44),
]  # fmt: skip
_VCP215 = [
    (0.5, 1, 17), (0.5, 5, 52),  # split cut
    (0.9, 1, 17), (0.9, 5, 52),  # split cut
    (1.3, 1, 17), (1.3, 5, 52),  # split cut
    (1.8, 5, 45), (2.4, 5, 45), (3.1, 5, 45), (4.0, 5, 45), (5.1, 5, 45), (6.4, 5, 45),  # batch
    (8.0, 6, 46), (10.0, 6, 46), (12.0, 6, 46), (14.0, 6, 46), (16.7, 6, 46), (19.5, 6, 46),
]  # fmt: skip

#: Named volume coverage patterns.
PRESETS: dict[str, tuple[Cut, ...]] = {"vcp212": _cuts(_VCP212), "vcp215": _cuts(_VCP215)}


def preset_key(name: str) -> str:
    """``VCP 212``, ``vcp212`` and ``212`` all name the preset ``vcp212``."""
    key = name.strip().lower().replace(" ", "").replace("_", "")
    return key if key.startswith("vcp") else f"vcp{key}"


def parse_cuts(text: str) -> tuple[list[Cut], list[str]]:
    """Cuts written ``ELEVATION_DEG PRT_S PULSES [AZ0:AZ1]``, separated by ``;``, and the
    problems found (each naming the cut), all of them."""
    cuts: list[Cut] = []
    problems: list[str] = []
    for n, item in enumerate((t for t in text.split(";") if t.strip()), start=1):
        fields = item.split()
        where = f"cut {n} ({item.strip()!r})"
        if len(fields) not in (3, 4):
            problems.append(f"{where}: expected ELEVATION_DEG PRT_S PULSES [AZ0:AZ1]")
            continue
        try:
            el, prt = float(fields[0]), float(fields[1])
            pulses = int(fields[2])
        except ValueError:
            problems.append(f"{where}: elevation and PRT must be numbers, pulses an integer")
            continue
        sector = None
        if len(fields) == 4:
            try:
                a0, a1 = (float(x) for x in fields[3].split(":"))
                sector = (a0 % 360.0, a1 % 360.0 or (360.0 if a1 else 0.0))
            except ValueError:
                problems.append(f"{where}: the sector must be AZ0:AZ1 in degrees")
                continue
        if not (math.isfinite(el) and -2.0 <= el <= 90.0):
            problems.append(f"{where}: elevation {el:g} deg is outside -2 to 90 deg")
        elif not (math.isfinite(prt) and 1e-5 <= prt <= 0.1):
            problems.append(f"{where}: PRT {prt:g} s is outside 1e-05 to 0.1 s")
        elif not 2 <= pulses <= 4096:
            problems.append(f"{where}: {pulses} pulses is outside 2 to 4096")
        elif sector is not None and sector[0] == sector[1]:
            problems.append(f"{where}: the sector's ends are equal and hold no beam")
        else:
            cuts.append(Cut(el, prt, pulses, sector))
    if not cuts and not problems:
        problems.append("no cut given")
    return cuts, problems
