"""Figure and numbers of docs/export.md: a run exported in every format and read back.

    python benchmarks/export_figure.py [--out docs] [--sector 290:330]

Runs the generic radar (graphs/generic_radar.yaml) over a sector of the bundled storm, exports
it with ``pasim export`` as CF/Radial 1, CF/Radial 2 and ODIM_H5, reads each file back with
Py-ART (``read_cfradial``, its xradar bridge, ``aux_io.read_odim_h5``) and prints, for each
format and field, the largest difference from the store and the number of gates whose data /
no-data state differs. Writes export_pyart.png: the estimated DBZH and the truth DBZH as
Py-ART draws them from the ODIM file, and the ODIM quantisation error of DBZH against its bound.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default=str(ROOT / "docs"))
    parser.add_argument("--sector", default="290:330")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pyart
    import xarray as xr
    from pasim_blocks.products.exchange_files import FORMATS, MOMENTS, odim_bound

    from pasim_graph.cli import main as pasim

    work = Path(tempfile.mkdtemp())
    store = work / "storm.zarr"
    graph = str(ROOT / "graphs" / "generic_radar.yaml")
    assert pasim(["run", graph, "--sector", args.sector, "--out", str(store)]) == 0
    files = {fmt: work / f"storm_{fmt}{suffix}" for fmt, (_, suffix) in FORMATS.items()}
    for fmt, path in files.items():
        assert pasim(["export", str(store), "--format", fmt, "--out", str(path)]) == 0
    want = xr.open_datatree(store, engine="zarr")["sweep_0"].to_dataset().sortby("azimuth")
    readers = {
        "cfradial1": lambda p: pyart.io.read_cfradial(p),
        "cfradial2": lambda p: xr.open_datatree(p).pyart.to_radar(),
        "odim": lambda p: pyart.aux_io.read_odim_h5(p, file_field_names=True),
    }
    radars = {}
    header = ("format", "field", "max |file - store|", "bound", "no-data differs")
    print("{:10s} {:12s} {:>20s} {:>8s} {:>16s}".format(*header))
    for fmt, path in files.items():
        radar = radars[fmt] = readers[fmt](str(path))
        order = np.argsort(radar.azimuth["data"] % 360.0)
        for name in [*MOMENTS, *(f"truth_{m}" for m in MOMENTS)]:
            got = np.ma.filled(radar.fields[name]["data"][order].astype(np.float64), np.nan)
            ref = want[name].values
            error = float(np.nanmax(np.abs(got - ref)))
            bound = odim_bound(name) if fmt == "odim" else 0.0
            differs = int((np.isnan(got) != np.isnan(ref)).sum())
            print(f"{fmt:10s} {name:12s} {error:20.6g} {bound:8.4g} {differs:16d}")
    gates = int(np.isfinite(want["DBZH"].values).sum())
    print(f"{want.sizes['azimuth']} beams x {want.sizes['range']} gates, {gates} with DBZH")

    radar = radars["odim"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    display = pyart.graph.RadarDisplay(radar)
    for ax, name in zip(axes[:2], ("DBZH", "truth_DBZH"), strict=True):
        display.plot(name, ax=ax, vmin=-10, vmax=70, cmap="HomeyerRainbow", colorbar_label="dBZ")
        ax.set_title(f"{name}: ODIM_H5 export read by Py-ART", fontsize=10)
        ax.set_xlim(-200, 20)
        ax.set_ylim(-20, 200)
        ax.set_aspect("equal")
    order = np.argsort(radar.azimuth["data"] % 360.0)
    got = np.ma.filled(radar.fields["DBZH"]["data"][order].astype(np.float64), np.nan)
    error = (got - want["DBZH"].values).ravel()
    error = error[np.isfinite(error)]
    bound = odim_bound("DBZH")
    axes[2].hist(error, bins=41, color="0.4")
    for x in (-bound, bound):
        axes[2].axvline(x, color="C3", ls="--")
    axes[2].set_xlabel("DBZH in the ODIM file minus the store's (dB)")
    axes[2].set_ylabel("gates")
    axes[2].set_title(f"ODIM uint16, gain 0.01 dB: bound +-{bound:.4f} dB", fontsize=10)
    fig.tight_layout()
    out = Path(args.out) / "export_pyart.png"
    fig.savefig(out, dpi=80)
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
