"""Figure and numbers of docs/volume.md: an RHI through the bundled volume's convective line.

    python benchmarks/volume_figures.py [--out docs]

The generic radar's 1 deg pencil beam at one azimuth (299.75 deg), elevations 0.5 to 19.5 deg
every 0.5 deg, at the ``expected`` level, over the volume truth read nearest and linear in
elevation; reflectivity against height at three ranges beside the truth's own sweeps. Prints
the largest step between neighbouring beams against the truth's largest step between
neighbouring sweeps, and writes volume_rhi.png.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pasim_blocks.antennas.pencil import PencilBeamAntenna  # noqa: E402
from pasim_blocks.truth.volume import beam_height  # noqa: E402

from tests.truth.test_volume_truth import beams_at, expected_dbz, volume_truth  # noqa: E402

AZIMUTH = 299.75
RANGES_KM = (68.0, 80.0, 104.0)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default=str(ROOT / "docs"))
    out = Path(parser.parse_args().out)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    warnings.simplefilter("ignore")
    elevation = np.arange(0.5, 19.51, 0.5)
    fig, axes = plt.subplots(1, len(RANGES_KM), figsize=(12, 4.5), sharey=True)
    for method, style in (("nearest", "-"), ("linear", "--")):
        truth = volume_truth(299.0, 300.5, margin=3.5, elevation_interpolation=method)
        beams = beams_at(truth, AZIMUTH, elevation)
        dbz, _ = expected_dbz(truth, beams, PencilBeamAntenna(name="a", support_deg=3.0))
        r = truth["range"].values
        j = int(np.argmin(np.abs(truth["azimuth"].values - AZIMUTH)))
        sweeps = truth["sweep_elevation"].values
        for ax, km in zip(axes, RANGES_KM, strict=True):
            g = int(np.argmin(np.abs(r - km * 1e3)))
            column = truth["volume_DBZH"].values[:, j, g]
            h_beam = beam_height(r[g], elevation) / 1e3
            ax.plot(dbz[:, g], h_beam, style, label=f"1 deg beam, {method}")
            if method == "nearest":
                ax.plot(column, truth["height"].values[:, g] / 1e3, "ko", label="truth sweeps")
                ax.set_title(f"{r[g] / 1e3:.1f} km, azimuth {AZIMUTH} deg")
                ax.set_xlabel("DBZH (dBZ)")
            have = np.flatnonzero(np.isfinite(column))
            top = sweeps[have[-1]]
            inside = elevation <= top
            steps = np.abs(np.diff(dbz[inside, g]))
            truth_step = np.nanmax(np.abs(np.diff(column[: have[-1] + 1])))
            print(
                f"{method:8s} {r[g] / 1e3:6.1f} km: largest beam-to-beam step "
                f"{steps.max():5.1f} dB, truth's largest sweep-to-sweep step {truth_step:5.1f} dB"
            )
    axes[0].set_ylabel("height above the radar (km, 4/3 earth)")
    for ax in axes:
        ax.set_ylim(0, 16)
        ax.set_xlim(-10, 65)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    fig.suptitle("RHI through the KLBB convective line: the generic radar over the volume truth")
    fig.tight_layout()
    fig.savefig(out / "volume_rhi.png", dpi=100)
    print(f"wrote {out / 'volume_rhi.png'}")


if __name__ == "__main__":
    main()
