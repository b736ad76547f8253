"""Figures and numbers of docs/arrays.md, "Arrays of any geometry" (reproducible).

    python benchmarks/arrays_geometry_figures.py [--out docs]

Writes arrays_geometries.png (layouts, the ring against J0, the line's half-power width
against 0.886 lambda / (N d cos theta)) and arrays_conformal_cylinder.png (the 10 m CPPAR
from its element file against antenna.cylindrical), and prints the numbers the page quotes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"
LAMBDA = 299_792_458.0 / 2.8e9


def db(x: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(x))


def geometries(out: Path) -> None:
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.layouts import lattice_layout
    from pasim_blocks.antennas.measures import half_power_beamwidth_deg
    from pasim_blocks.antennas.shaped import LinearArray, RingArray
    from scipy.special import j0

    fig, ax = plt.subplots(2, 2, figsize=(12, 9.5))
    a = ax[0, 0]
    for lattice, marker, shift in (("rectangular", "s", 0.0), ("triangular", "^", 0.6)):
        layout = lattice_layout(8, 6, 0.0524, 0.0524, 0.0, 0.0, lattice)
        p = layout.positions().reshape(-1, 3)
        a.plot(p[:, 0] + shift, p[:, 2], marker, ms=5, ls="none", label=lattice)
    a.set(xlabel="across the face (m)", ylabel="up (m)", aspect="equal")
    a.set_title("antenna.lattice: rectangular | triangular")
    a.set_ylim(-0.35, 0.2)
    a.legend(loc="lower center", fontsize=8, ncol=2)

    a = ax[0, 1]
    ring = RingArray(name="ring", elements=96, radius_m=0.8, arc_deg=240.0, centre_azimuth_deg=0.0)
    layout = ring.layout
    active = ring.active(30.0)
    xy = layout.column_position[:, :2]
    a.plot(xy[:, 0], xy[:, 1], ".", color="0.6", label="columns (240 deg arc)")
    a.plot(xy[active, 0], xy[active, 1], ".", color="C3", label="active for a beam at 30 deg")
    n = layout.normal[active][::4]
    a.quiver(*xy[active][::4].T, *n[:, :2].T, scale=12, width=0.004, color="C3")
    a.plot([0, np.sin(np.deg2rad(30)) * 1.4], [0, np.cos(np.deg2rad(30)) * 1.4], "k--", lw=1)
    a.set(xlabel="east (m)", ylabel="north (m)", aspect="equal")
    a.set_title("antenna.ring: an arc, its commutated sector and normals")
    a.legend(loc="lower center", fontsize=8)

    a = ax[1, 0]
    k = 2 * np.pi / LAMBDA
    radius = 25.6 / k
    omni = RingArray(
        name="ring", elements=64, radius_m=radius, element="omni", taper="uniform",
        active_sector_deg=360.0, support_deg=1.0, grid_step_deg=0.5,
    )  # fmt: skip
    d = np.linspace(-30.0, 30.0, 1201)
    f = omni.fields_at(285.0, 0.0, 285.0 + d, np.zeros_like(d))
    closed = db(j0(2 * k * radius * np.sin(np.deg2rad(d) / 2)))
    got = db(f.h_co) - db(f.h_co).max()
    a.plot(d, closed, lw=3, color="0.7", label="J0(2 k a sin(dphi/2)), Balanis 6-119")
    a.plot(d, got, color="C0", lw=1, label="antenna.ring, 64 omni elements, ka = 25.6")
    a.set(xlabel="azimuth from the beam (deg)", ylabel="one-way power (dB)", ylim=(-70, 2))
    a.set_title(f"full ring against J0: largest difference {np.max(np.abs(got - closed)):.1e} dB")
    a.legend(loc="lower center", fontsize=8)
    print(f"ring vs J0 over +-30 deg: max |diff| {np.max(np.abs(got - closed)):.2e} dB")

    a = ax[1, 1]
    thetas = np.arange(0.0, 61.0, 5.0)
    for n_el, colour in ((16, "C0"), (32, "C1"), (64, "C2")):
        line = LinearArray(
            name="line", elements=n_el, spacing_m=LAMBDA / 2, taper="uniform",
            element="isotropic", face_azimuth_deg=0.0, support_deg=1.0, grid_step_deg=0.5,
        )  # fmt: skip
        widths, theory = [], []
        d = np.arange(-25.0, 25.0, 0.002)
        for theta in thetas:
            f = line.fields_at(theta, 0.0, theta + d, np.zeros_like(d))
            widths.append(half_power_beamwidth_deg(d, np.abs(f.h_co) ** 2))
            theory.append(np.rad2deg(0.886 * 2 / (n_el * np.cos(np.deg2rad(theta)))))
        widths_a, theory_a = np.array(widths), np.array(theory)
        a.plot(thetas, widths_a, "o", color=colour, ms=4, label=f"antenna.linear, N = {n_el}")
        a.plot(thetas, theory_a, "-", color=colour, lw=1)
        worst = np.abs(widths_a / theory_a - 1)
        print(
            f"line N={n_el}: width / theory - 1 at 0, 30, 45, 60 deg: "
            + ", ".join(f"{worst[list(thetas).index(t)]:.2%}" for t in (0, 30, 45, 60))
        )
    a.set(xlabel="steering off broadside (deg)", ylabel="half-power width (deg)", yscale="log")
    a.set_title("uniform line, d = lambda/2; lines: 0.886 lambda / (N d cos theta)")
    a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "arrays_geometries.png", dpi=110)
    plt.close(fig)


def conformal_cylinder(out: Path) -> None:
    import matplotlib.pyplot as plt
    from pasim_blocks.antennas.beam_figures import build

    from pasim_graph import load

    cylinder = build(load(GRAPHS / "cppar10_radar.yaml"), "antenna")
    conformal = build(
        load(GRAPHS / "conformal_file.yaml"), "antenna", path=str(GRAPHS / "cppar10_elements.csv")
    )
    resource = conformal.load()
    steer = ((413 + 77.5 + 0.35) * 360.0 / 624, 0.5)  # 0.35 columns off a sector centre
    d = np.arange(-10.0, 10.0001, 0.01)
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), sharex="col", height_ratios=(3, 1))
    for col, (name, az, el) in enumerate(
        (
            ("azimuth", steer[0] + d, np.full_like(d, steer[1])),
            ("elevation", np.full_like(d, steer[0]), steer[1] + d),
        )
    ):
        a = cylinder.fields_at(*steer, az, el)
        b = conformal.fields_at(*steer, az, el, 0, resource)
        for port, colour in (("h_co", "C0"), ("v_co", "C1")):
            ref, got = db(getattr(a, port)), db(getattr(b, port))
            ax[0, col].plot(d, ref, lw=3, color="0.75" if port == "h_co" else "0.55")
            ax[0, col].plot(d, got, lw=0.8, color=colour, label=f"{port[0].upper()}, file")
            lobes = ref > ref.max() - 45.0
            ax[1, col].plot(d[lobes], (got - ref)[lobes], ".", ms=1, color=colour)
            print(
                f"{name} cut, {port}: max |file - cylindrical| within 45 dB of the peak "
                f"{np.max(np.abs(got - ref)[lobes]):.1e} dB"
            )
        ax[0, col].set(ylim=(-70, 2), ylabel="one-way power (dB)")
        ax[0, col].set_title(f"{name} cut")
        ax[0, col].legend(fontsize=8, loc="upper right")
        ax[1, col].set(xlabel=f"{name} from the beam (deg)", ylabel="file - cyl. (dB)")
    fig.suptitle(
        "10 m CPPAR, beam at {:.2f} deg, {} deg up: grey antenna.cylindrical, colour "
        "antenna.conformal\nfrom graphs/cppar10_elements.csv (79,872 elements)".format(*steer)
    )
    fig.tight_layout()
    fig.savefig(out / "arrays_conformal_cylinder.png", dpi=110)
    plt.close(fig)
    print(f"gain: file {conformal.pattern_gain_db(resource):.4f} dBi, "
          f"cylindrical {cylinder.pattern_gain_db():.4f} dBi")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    args = parser.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    geometries(args.out)
    conformal_cylinder(args.out)


if __name__ == "__main__":
    main()
