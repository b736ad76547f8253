"""Azimuth beamwidth and first sidelobe of the paper's arrays for candidate tapers and elements.

    python benchmarks/arrays_taper_scan.py [atd|c10|c2 ...]

Prints, for each candidate, the H and V ports' one-way 3-dB azimuth width and first sidelobe
at broadside (``pasim pattern``'s measurement, +-25 deg at 0.005 deg) and the peak gain; the
tables of docs/arrays.md ("How the tapers were chosen") come from it. Columns hold 16
elements: the azimuth cut at 0 deg elevation does not depend on the column height.
"""

from __future__ import annotations

import sys

from pasim_blocks.antennas.beam_figures import measure
from pasim_blocks.antennas.cylindrical import CylindricalArray
from pasim_blocks.antennas.planar import PlanarPatchArray

ELEMENTS = ("patch", "isotropic", "crossed_dipole")


def row(block, label: str) -> None:
    m = measure(block, 0, 0, span_deg=25, step_deg=0.005)
    print(
        f"{label:55s} H {m['beamwidth_az_deg']:.3f} {m['first_sidelobe_db']:7.2f}  "
        f"V {m['beamwidth_az_v_deg']:.3f} {m['first_sidelobe_v_db']:7.2f}  "
        f"gain {m['peak_gain_dbi']:.2f}",
        flush=True,
    )


def atd() -> None:
    for taper, extra in [
        ("taylor", {"taylor_sll_db": -30}),
        ("taylor", {"taylor_sll_db": -35}),
        ("taylor", {"taylor_sll_db": -40}),
        ("kaiser", {"kaiser_beta": 4.0}),
        ("kaiser", {"kaiser_beta": 4.2}),
    ]:
        for element in ELEMENTS:
            block = PlanarPatchArray(
                name="a", taper=taper, element=element, grid_step_deg=0.5, support_deg=1, **extra
            )
            row(block, f"ATD {element} {taper} {extra}")


def cylinder(which: str) -> None:
    geometry = (
        {"diameter_m": 10.0, "columns": 624, "excited_columns": 156}
        if which == "c10"
        else {"diameter_m": 2.0, "columns": 96, "excited_columns": 24}
    )
    for taper, extra, axis in [
        ("taylor", {"taylor_sll_db": -30}, "columns"),
        ("taylor", {"taylor_sll_db": -35}, "columns"),
        ("taylor", {"taylor_sll_db": -30}, "projected"),
        ("kaiser", {"kaiser_beta": 4.0}, "columns"),
        ("kaiser", {"kaiser_beta": 4.5}, "columns"),
    ]:
        for element in ELEMENTS:
            block = CylindricalArray(
                name="a",
                taper=taper,
                element=element,
                taper_axis=axis,
                elements_per_column=16,
                grid_step_deg=0.5,
                support_deg=1,
                **geometry,
                **extra,
            )
            row(block, f"{which} {element} {taper} {axis} {extra}")


if __name__ == "__main__":
    for which in sys.argv[1:] or ["atd", "c10", "c2"]:
        atd() if which == "atd" else cylinder(which)
