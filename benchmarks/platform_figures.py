"""The pictures of docs/platform.md: the storm seen from 40 km east (truth.elsewhere), a 10 deg
roll's beams against a rotation by hand, the airborne velocity error and broadening on a still
scene with and without motion compensation, and graphs/airborne_xband.yaml's DBZH.

Run from the top of the repository: ``python benchmarks/platform_figures.py`` (about a minute
on 2 cores; it writes docs/platform_*.png).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from pasim_blocks.scans.platform import earth_pointing
from pasim_blocks.truth.elsewhere import ElsewhereTruth
from pasim_blocks.truth.nexrad import NexradTruth

from pasim_graph import Chunk
from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def elsewhere() -> None:
    block = NexradTruth(name="truth", sweeps="volume", elevation_min_deg=0.5, elevation_max_deg=2.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["truth"]
        view = ElsewhereTruth(name="view", east_m=40e3, velocity="omit").process(
            {"truth_in": truth}, Chunk(beams=np.arange(0))
        )["truth"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 5), sharey=True)
    for ax, ds, x0, title in (
        (axes[0], truth, 0.0, "KLBB's 0.5 deg sweep (the truth radar)"),
        (axes[1], view, 40.0, "the truth read from 40 km east, 0.5 deg"),
    ):
        az = np.deg2rad(ds["azimuth"].values)[:, None]
        r = ds["range"].values[None, :] / 1e3
        mesh = ax.pcolormesh(
            x0 + r * np.sin(az), r * np.cos(az), ds["DBZH"].values, vmin=0, vmax=60, cmap="turbo"
        )
        ax.plot([0], [0], "k^", ms=8)
        ax.plot([40], [0], "ko", ms=8)
        ax.set_xlim(-150, 60)
        ax.set_ylim(-60, 150)
        ax.set_aspect(1)
        ax.set_title(title)
        ax.set_xlabel("east of KLBB (km)")
    axes[0].set_ylabel("north of KLBB (km)")
    fig.colorbar(mesh, ax=axes, label="DBZH (dBZ)", shrink=0.8)
    fig.savefig(DOCS / "platform_elsewhere.png", dpi=80)
    plt.close(fig)


def rodrigues(v: np.ndarray, k: np.ndarray, angle_deg: float) -> np.ndarray:
    a = np.deg2rad(angle_deg)
    return v * np.cos(a) + np.cross(k, v) * np.sin(a) + k * np.dot(k, v) * (1 - np.cos(a))


def roll() -> None:
    az_a = np.arange(0.0, 181.0, 15.0)
    fig, ax = plt.subplots(figsize=(8, 4))
    for roll_deg, style in ((0.0, "o-"), (10.0, "s-")):
        az, el = earth_pointing(az_a, np.full(az_a.size, 2.0), 0.0, 0.0, roll_deg)
        ax.plot(az, el, style, label=f"roll {roll_deg:g} deg (scan.ppi's platform)")
    hand = []
    for a in np.deg2rad(az_a):
        v = np.array([np.sin(a) * np.cos(np.deg2rad(2)), np.cos(a) * np.cos(np.deg2rad(2)), 0.0])
        v[2] = np.sin(np.deg2rad(2.0))
        r = rodrigues(v, np.array([0.0, 1.0, 0.0]), 10.0)
        hand.append((np.rad2deg(np.arctan2(r[0], r[1])) % 360, np.rad2deg(np.arcsin(r[2]))))
    hand_arr = np.array(hand)
    ax.plot(hand_arr[:, 0], hand_arr[:, 1], "k+", ms=12, label="rotation about the nose by hand")
    ax.set_xlabel("earth azimuth (deg)")
    ax.set_ylabel("earth elevation (deg)")
    ax.set_title("Beams steered 0-180 deg from the nose at 2 deg, heading north")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(DOCS / "platform_roll.png", dpi=80)
    plt.close(fig)


def motion() -> None:
    sets = {
        "scan.platform": "airborne",
        "scan.azimuth_start_deg": 80.0,
        "scan.azimuth_stop_deg": 100.0,
        "scan.beam_spacing_deg": 1.0,
        "scan.elevation_deg": 0.0,
        "scene.velocity_ms": 0.0,
        "scene.gates": 40,
        "weather.method": "covariance",
    }

    def run(**more: object) -> object:
        graph = load(ROOT / "graphs" / "uniform_ideal.yaml", {**sets, **more})
        return LocalExecutor(graph, RunOptions(seed=5)).run()

    raw, fixed = run(), run(**{"ppp.motion_compensation": True})
    still = run(**{"scan.platform": "ground"})
    az = raw["azimuth"].values
    vp = raw["platform_radial_velocity"].values
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ax = axes[0]
    ax.plot(az, np.nanmean(raw["VRADH"].values, axis=1), "o", label="estimate, uncompensated")
    ax.plot(az, -vp, "k-", label="minus the platform velocity on the beam")
    ax.plot(az, np.nanmean(fixed["VRADH"].values, axis=1), "s", label="motion compensated")
    ax.set_xlabel("beam azimuth (deg)")
    ax.set_ylabel("mean VRADH (m/s)")
    ax.set_title("Still uniform scene from 150 m/s (covariance level)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[1]
    w = np.nanmean(raw["WRADH"].values, axis=1)
    w0 = np.nanmean(still["WRADH"].values, axis=1)
    closed = 150 * np.abs(np.sin(np.deg2rad(az))) * np.deg2rad(1.0) / (4 * np.sqrt(np.log(2)))
    ax.plot(az, np.sqrt(np.maximum(w**2 - w0**2, 0)), "o", label="sqrt(W^2 - W_still^2)")
    ax.plot(az, closed, "k-", label="0.3 v_perp theta_1 (Doviak and Zrnic)")
    ax.set_ylim(0, 1.2)
    ax.set_xlabel("beam azimuth (deg)")
    ax.set_ylabel("platform broadening (m/s)")
    ax.set_title("Motion broadening, ideal 1 deg beam")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(DOCS / "platform_motion.png", dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    roll()
    motion()
    elsewhere()
