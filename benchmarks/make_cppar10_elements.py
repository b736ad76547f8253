"""Write graphs/cppar10_elements.csv: the 10 m CPPAR of graphs/cppar10_radar.yaml (antenna
.cylindrical: 624 columns round a 10 m cylinder, 128 elements 5.24 cm apart up each, column 0
facing north) as a file of element positions and outward normals, one T/R channel per column
(channel = the cylinder's column index), for antenna.conformal (graphs/conformal_file.yaml).

    python benchmarks/make_cppar10_elements.py [OUT.csv]
"""

from __future__ import annotations

import sys
from pathlib import Path

from pasim_blocks.antennas.layouts import ring_layout, write_element_file

COLUMNS, DIAMETER_M, PER_COLUMN, SPACING_M = 624, 10.0, 128, 0.0524


def main(out: str = "graphs/cppar10_elements.csv") -> None:
    step = 360.0 / COLUMNS
    # ring_layout centres its columns on the arc's centre; column 0 at azimuth 0 puts the
    # centre (COLUMNS - 1) / 2 columns round from it.
    layout = ring_layout(
        COLUMNS, DIAMETER_M / 2, 360.0, (COLUMNS - 1) / 2 * step, PER_COLUMN, SPACING_M
    )
    write_element_file(
        out,
        layout,
        comment=(
            f"10 m CPPAR (graphs/cppar10_radar.yaml): {COLUMNS} columns x {PER_COLUMN} elements,\n"
            "column 0 facing north; x_m, y_m, z_m east-north-up from the cylinder's centre;\n"
            "channel = column (one T/R module per column). Written by "
            "benchmarks/make_cppar10_elements.py"
        ),
    )
    print(f"{out}: {COLUMNS * PER_COLUMN} elements, {Path(out).stat().st_size / 2**20:.1f} MiB")


if __name__ == "__main__":
    main(*sys.argv[1:])
