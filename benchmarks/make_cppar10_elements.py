"""Write graphs/cppar10_elements.csv: the antenna of graphs/cppar10_radar.yaml (antenna
.cylindrical: 624 columns round a 10 m cylinder, 128 elements 5.24 cm apart up each, column 0
facing north) as a file of element positions and outward normals, one T/R channel per column
(channel = the cylinder's column index), for antenna.conformal (graphs/conformal_file.yaml).
The positions are the cylinder block's own (``CylindricalArray.element_layout``).

    python benchmarks/make_cppar10_elements.py [OUT.csv]
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(out: str = str(ROOT / "graphs" / "cppar10_elements.csv")) -> None:
    from pasim_blocks.antennas.beam_figures import build
    from pasim_blocks.antennas.layouts import write_element_file

    from pasim_graph import load

    cylinder = build(load(ROOT / "graphs" / "cppar10_radar.yaml"), "antenna")
    layout = cylinder.element_layout()  # type: ignore[attr-defined]
    columns, per_column = layout.channel.shape
    write_element_file(
        out,
        layout,
        comment=(
            f"10 m CPPAR (graphs/cppar10_radar.yaml): {columns} columns x {per_column} elements,\n"
            "column 0 facing north; x_m, y_m, z_m east-north-up from the cylinder's centre;\n"
            "channel = column (one T/R module per column). Written by "
            "benchmarks/make_cppar10_elements.py"
        ),
    )
    print(f"{out}: {columns * per_column} elements, {Path(out).stat().st_size / 2**20:.1f} MiB")


if __name__ == "__main__":
    main(*sys.argv[1:])
