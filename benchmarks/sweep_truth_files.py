"""Truth from any file: every radar file at hand run as the truth of a simulated radar.

    python benchmarks/sweep_truth_files.py                # ../shared/data + Py-ART's samples
    python benchmarks/sweep_truth_files.py --fixtures     # tests/fixtures/truth only (fast)
    python benchmarks/sweep_truth_files.py --markdown table.md FILE ...

Each file is planned from its own content, then run through ``pasim run`` in this process
(the command's own checks and messages, as a user sees them):

* a NEXRAD Level-II volume or a file of PPIs: ``graphs/generic_radar.yaml`` at the file's
  lowest elevation, over 3 deg centred on the radial with the most echo (10 dBZ or more);
* a file of RHIs only: ``graphs/generic_rhi.yaml`` at its middle RHI's azimuth, 6 beams
  from 0.5 to 3 deg;
* a file no reader opens, or without a field to take reflectivity from: the default run,
  which refuses it.

Every run is at the weather channel's ``expected`` level (no noise drawn: the fastest). A
file either runs (its moments and the file's field each came from are reported, with the
gates scored) or is refused with one line (exit 2); anything else (a traceback, a block
failing, a refusal of more than one line) is a failure of the program, listed as FAILED.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import sys
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GENERIC = ROOT / "graphs" / "generic_radar.yaml"
RHI = ROOT / "graphs" / "generic_rhi.yaml"
SHARED = ROOT.parent / "shared" / "data"
FIXTURES = ROOT / "tests" / "fixtures" / "truth"
MOMENTS = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
#: Level-II field names, for the report (the project's own reader takes them by number).
LEVEL2_NAMES = {"DBZH": "REF", "ZDR": "ZDR", "RHOHV": "RHO", "PHIDP": "PHI"}
LEVEL2_NAMES |= {"VRADH": "VEL", "WRADH": "SW"}
#: 4/3 of the earth's radius (km): the beam's height in the pictures of RHIs.
FOUR_THIRDS_EARTH_KM = 4.0 / 3.0 * 6371.0


@dataclass
class Outcome:
    """What one file gave: ``status`` is ``runs``, ``refused`` or ``FAILED``."""

    path: Path
    source: str
    status: str = ""
    format: str = ""
    setting: str = ""
    moments: dict[str, str] = field(default_factory=dict)
    scored: dict[str, int] = field(default_factory=dict)
    message: str = ""
    args: list[str] = field(default_factory=list)

    def setting_of(self, name: str) -> str | None:
        """The value the run gave ``--set NAME=...`` (or ``--sector`` for ``sector``)."""
        for flag, value in zip(self.args, self.args[1:], strict=False):
            if name == "sector" and flag == "--sector":
                return value
            if flag == "--set" and value.startswith(f"{name}="):
                return value.split("=", 1)[1]
        return None

    def row(self) -> str:
        if self.status == "runs":
            found = ", ".join(
                f"{m} ({self.moments[m]}, {self.scored.get(m, 0)} gates)"
                for m in MOMENTS
                if m in self.moments
            )
            result = f"runs: {found}" if found else "runs: no truth in the sector"
        else:
            result = f"{self.status}: {_bare(self.message)}"
        name = f"`{self.path.name}`"
        return f"| {name} | {self.source} | {self.format} | {self.setting} | {result} |"


def sample_files() -> list[tuple[Path, str]]:
    """Py-ART's sample files (``pyart.testing.sample_files``), as (path, source)."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            from pyart.testing import sample_files
    except ImportError:
        return []
    names = sorted(n for n in dir(sample_files) if n.isupper() and n != "DATA_PATH")
    paths = {Path(getattr(sample_files, n)) for n in names}
    return [(p, "Py-ART sample") for p in sorted(paths) if p.is_file()]


def all_files(fixtures_only: bool = False) -> list[tuple[Path, str]]:
    """The files of the sweep: the fixtures, or ``../shared/data`` and Py-ART's samples."""
    if fixtures_only:
        folders = [(FIXTURES, "tests/fixtures/truth")]
    else:
        folders = [(SHARED, "../shared/data")]
    out = [
        (p, label)
        for folder, label in folders
        if folder.is_dir()
        for p in sorted(folder.iterdir())
        if p.is_file() and p.suffix not in (".md", ".py")
    ]
    return out if fixtures_only else out + sample_files()


def _busiest_azimuth(azimuth: np.ndarray, dbzh: np.ndarray | None) -> float:
    """The azimuth of the radial with the most gates of 10 dBZ or more."""
    if dbzh is None or not np.isfinite(dbzh).any():
        return float(azimuth[azimuth.size // 2])
    counts = np.sum(np.nan_to_num(dbzh, nan=-99.0) >= 10.0, axis=1)
    return float(azimuth[int(np.argmax(counts))])


def _fit(azimuth: np.ndarray, centre: float, half: float) -> tuple[float, list[str], str]:
    """Beams ``centre`` +- ``half`` inside a file that covers a sector only: the centre moved
    inside and the antenna's pattern support narrowed to stay within it (the weather channel
    refuses a pattern that reaches past the truth); the whole circle: unchanged."""
    from pasim_blocks.truth.gridding import nominal_spacing
    from pasim_blocks.weather.coverage import truth_span

    span = truth_span(azimuth, float(nominal_spacing(azimuth)))
    if span is None:
        return centre, [], ""
    start, extent = span
    inside = float(np.clip((centre - start) % 360.0, half + 2.0, max(extent - half - 2.0, 0.0)))
    if extent < 2 * half + 4.0:
        inside = extent / 2
    support = float(np.floor(min(10.0, inside - half, extent - inside - half) * 10) / 10)
    support = max(support, 0.5)
    if support >= 10.0:  # the generic radar's own
        return (start + inside) % 360.0, [], ""
    args = ["--set", f"antenna.support_deg={support:g}"]
    return (start + inside) % 360.0, args, f", pattern support {support:g} deg"


def _ppi(path: Path, elevation: float, sweep: Any) -> tuple[list[str], str]:
    """``pasim run`` of the generic radar over 3 deg about the busiest radial of a PPI (a
    truth sweep of the file, read whole)."""
    azimuth = np.asarray(sweep.azimuth_deg, np.float64) % 360.0
    centre, narrow, note = _fit(azimuth, _busiest_azimuth(azimuth, sweep.fields.get("DBZH")), 1.5)
    centre = round(centre, 1)
    sector = f"{(centre - 1.5) % 360:g}:{(centre + 1.5) % 360:g}"
    if sweep.radial_width_deg > 1.5:  # radials far apart: read one more either side
        margin = np.ceil(10.0 + 2 * sweep.radial_width_deg)
        narrow += ["--set", f"truth.margin_deg={margin:g}"]
        note += f", truth margin {margin:g} deg ({sweep.radial_width_deg:.1f} deg radials)"
    args = ["run", str(GENERIC), "--truth", str(path), *QUICK, "--sector", sector, *narrow]
    args += ["--set", f"truth.elevation_deg={elevation:g}"]
    args += ["--set", f"scan.elevation_deg={elevation:g}"]
    return args, f"generic radar, {sector} deg at {elevation:.2f} deg{note}"


QUICK = ["--set", "weather.method=expected"]


def plan(path: Path) -> tuple[list[str], str, str, dict[str, str]]:
    """(arguments of ``pasim run`` for the file, its format, the setting in words, moment ->
    the file's field), from the file's content; a file this cannot read gets the default run
    (which refuses it with its own message)."""
    from pasim_blocks.truth.nexrad_io import read_truth_sweep
    from pasim_blocks.truth.radar_files import (
        is_level2,
        open_radar_file,
        sweep_modes,
        sweeps_from_tree,
    )

    default = ["run", str(GENERIC), "--truth", str(path), *QUICK]
    if is_level2(path):
        try:
            sweep = read_truth_sweep(path, 0.5)
        except (ValueError, OSError):
            return default, "NEXRAD Level-II", "default run", {}
        args, words = _ppi(path, 0.5, sweep)
        return args, "NEXRAD Level-II", words, {m: LEVEL2_NAMES[m] for m in sweep.fields}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tree, kind = open_radar_file(path)
            described = sweep_modes(tree, str(path))
    except (ValueError, OSError):
        return default, "", "default run", {}
    rhis = [d for d in described if "rhi" in d[2].lower()]
    ppis = [d for d in described if "rhi" not in d[2].lower()]
    if rhis and not ppis:
        name, azimuth, _ = sorted(rhis, key=lambda d: d[1])[len(rhis) // 2]
        angles = np.array([d[1] for d in rhis])
        _, narrow, note = _fit(angles, azimuth % 360.0, 0.0) if angles.size > 1 else (0, [], "")
        args = ["run", str(RHI), "--truth", str(path), *QUICK, *narrow]
        args += ["--set", f"scan.azimuth_deg={azimuth % 360:g}"]
        args += ["--set", "scan.elevation_stop_deg=3", "--set", "truth.elevation_max_deg=3"]
        words = f"RHI graph, azimuth {azimuth % 360:g} deg, 0.5-3 deg{note}"
        return args, kind, words, file_fields(tree[name].to_dataset())
    if not ppis:
        return default, kind, "default run", {}
    name, elevation, _ = min(ppis, key=lambda d: d[1])
    elevation = float(np.clip(elevation, -2.0, 90.0))
    mapping = file_fields(tree[name].to_dataset())
    try:  # the sweep as the truth block reads it (its radials, duplicates dropped)
        (truth,) = sweeps_from_tree(tree, kind, path, lambda _: [elevation], None, 0.0)
    except ValueError:
        return default, kind, "default run", mapping
    args, words = _ppi(path, elevation, truth)
    return args, kind, words, mapping


def file_fields(ds: Any) -> dict[str, str]:
    """moment -> the sweep's field it is taken from, as the truth block maps them."""
    from pasim_blocks.truth.field_names import field_map

    names = [str(n) for n in ds.data_vars if ds[n].ndim == 2]
    return field_map(names, {n: str(ds[n].attrs.get("standard_name", "")) for n in names})


def pasim(*argv: str) -> tuple[int | str, str, str]:
    """``pasim ARGV`` in this process: exit code (``"traceback"`` for an exception that
    escaped the command), standard output and standard error."""
    from pasim_graph.cli import main

    out, err = io.StringIO(), io.StringIO()
    code: int | str
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except Exception as exc:  # a traceback for a user: the program's fault
            code = "traceback"
            print(f"{type(exc).__name__}: {exc}", file=err)
    return code, out.getvalue(), err.getvalue()


def sweep_file(path: Path, source: str, work: Path) -> Outcome:
    """Plan and run one file; its outcome."""
    outcome = Outcome(path, source)
    try:
        args, outcome.format, outcome.setting, outcome.moments = plan(path)
        outcome.args = args
    except Exception as exc:  # the plan is this script's, not the program's: say so
        outcome.status, outcome.message = "FAILED", f"planning: {type(exc).__name__}: {exc}"
        return outcome
    store = work / f"{path.name}.zarr"
    code, _, err = pasim(*args, "--out", str(store))
    lines = [line for line in err.splitlines() if line.strip()]
    errors = [line for line in lines if not line.startswith(("note:", "warning:", "running "))]
    if code == 0:
        outcome.status = "runs"
        outcome.scored = scored_gates(store)
        outcome.moments = {m: n for m, n in outcome.moments.items() if m in outcome.scored}
    elif code == 2 and len(errors) == 1 and "Traceback" not in err and BLOCK_FAILED not in err:
        outcome.status, outcome.message = "refused", _short(errors[0], path)
        outcome.moments = {}
    else:
        outcome.status = "FAILED"
        outcome.message = f"exit {code}: " + " / ".join(_short(e, path) for e in errors[-3:])
    return outcome


#: How ``pasim run`` words a block that failed while computing: not a refusal of the input.
BLOCK_FAILED = "failed on beams"


def scored_gates(store: Path) -> dict[str, int]:
    """moment -> gates scored against the truth, for each moment the truth holds (what
    ``pasim score`` counts: the finite ``error_<moment>`` values; 0 where the sector has no
    echo the scorer takes)."""
    import xarray as xr

    sweep = xr.open_zarr(store, group="sweep_0")
    return {
        m: int(np.isfinite(sweep[f"error_{m}"].values).sum())
        for m in MOMENTS
        if f"truth_{m}" in sweep and f"error_{m}" in sweep
    }


def _bare(message: str) -> str:
    """A refusal as the table shows it: the reader's words, without the command's frame
    (``error: GRAPH: block 'truth' (truth.nexrad) failed while loading: ValueError:`` and
    ``(rerun with --debug for the traceback)``)."""
    text = re.sub(r"^error: \S+: block '\w+' \([\w.]+\) failed while loading: \w+: ", "", message)
    return text.removesuffix("(rerun with --debug for the traceback)").strip()


def _short(line: str, path: Path) -> str:
    """A message with the file's folder left out (the table names the file)."""
    for folder in (path.parent, ROOT):
        line = line.replace(f"{folder}/", "")
    return line.replace("|", "/").strip()


def sweep(files: list[tuple[Path, str]]) -> list[Outcome]:
    with tempfile.TemporaryDirectory(prefix="pasim-sweep-") as work:
        return [sweep_file(p, source, Path(work)) for p, source in files]


def table(outcomes: list[Outcome]) -> str:
    head = "| File | From | Format | Run | Result: moments (the file's field, gates scored) |"
    rule = "|---|---|---|---|---|"
    return "\n".join([head, rule, *(o.row() for o in outcomes)]) + "\n"


def truth_view(outcome: Outcome) -> tuple[str, np.ndarray, np.ndarray, np.ndarray] | None:
    """What a file that ran gave as truth, to draw: (kind, x km, y km, DBZH) of its PPI
    (east, north) or its RHI at the run's azimuth (ground range, height), read as the truth
    block reads it; None for a file that did not run."""
    from pasim_blocks.truth.nexrad_io import read_truth_sweep
    from pasim_blocks.truth.radar_files import is_level2, open_radar_file, read_radar_sweep
    from pasim_blocks.truth.rhi_files import rhi_sweeps

    if outcome.status != "runs":
        return None
    if outcome.setting.startswith("RHI"):
        tree, kind = open_radar_file(outcome.path)
        sweeps = rhi_sweeps(tree, kind, outcome.path, lambda grid: grid)
        azimuth = float(outcome.setting_of("scan.azimuth_deg") or 0.0)
        row = int(np.argmin(np.abs(sweeps[0].azimuth_deg - azimuth)))
        angles = np.array([sw.elevation_deg for sw in sweeps])
        dbzh = np.array([sw.fields["DBZH"][row] for sw in sweeps])
        r, e = np.meshgrid(sweeps[0].range_m / 1e3, np.radians(angles))
        height = r * np.sin(e) + r**2 / (2 * FOUR_THIRDS_EARTH_KM)
        return "rhi", r * np.cos(e), height, dbzh
    elevation = float(outcome.setting_of("truth.elevation_deg") or 0.5)
    reader = read_truth_sweep if is_level2(outcome.path) else read_radar_sweep
    sweep = reader(outcome.path, elevation)
    a, r = np.meshgrid(np.radians(sweep.azimuth_deg), sweep.range_m / 1e3, indexing="ij")
    return "ppi", r * np.sin(a), r * np.cos(a), sweep.fields["DBZH"]


def figure(outcomes: list[Outcome], out: Path) -> None:
    """The reflectivity each file that ran gave as truth, a panel a file, with the sector
    (PPI) or the elevations (RHI) the simulated radar looked at."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    views = [(o, v) for o in outcomes if (v := truth_view(o)) is not None]
    cols = 4
    rows = -(-len(views) // cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(4.0 * cols, 3.8 * rows), squeeze=False, layout="constrained"
    )
    mesh = None
    for ax, (outcome, (kind, x, y, dbzh)) in zip(axes.ravel(), views, strict=False):
        shown = np.where(dbzh >= 0.0, dbzh, np.nan)  # echo of 0 dBZ or more
        mesh = ax.pcolormesh(
            x, y, shown, shading="nearest", cmap="turbo", vmin=0, vmax=60, rasterized=True
        )
        if kind == "ppi":
            ax.set_aspect("equal", adjustable="datalim")
            sector = outcome.setting_of("sector") or "0:0"
            reach = float(np.nanmax(np.hypot(x, y)))
            for edge in map(float, sector.split(":")):
                ax.plot(
                    [0, reach * np.sin(np.radians(edge))],
                    [0, reach * np.cos(np.radians(edge))],
                    color="k",
                    lw=0.8,
                )
            ax.set_xlabel("km east")
            ax.set_ylabel("km north")
        else:
            for edge in (0.5, 3.0):
                reach = float(np.nanmax(x))
                ax.plot([0, reach], [0, reach * np.tan(np.radians(edge))], color="k", lw=0.8)
            ax.set_xlabel("km along the ground")
            ax.set_ylabel("km above the radar")
        name = outcome.path.name
        label = name if len(name) < 32 else name[:29] + "..."
        ax.set_title(
            f"{label}\n{outcome.format}: DBZH from {outcome.moments.get('DBZH', '?')}", fontsize=9
        )
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(views) :]:
        ax.axis("off")
    if mesh is not None:
        fig.colorbar(mesh, ax=axes.ravel().tolist(), shrink=0.5, label="truth DBZH (dBZ)")
    fig.suptitle(
        "Truth from any file: the reflectivity each file gave (0 dBZ or more; black lines: the "
        "sector, or the 0.5-3 deg of an RHI, the simulated radar ran over)",
        fontsize=11,
    )
    fig.savefig(out, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="files to sweep (default: all)")
    parser.add_argument("--fixtures", action="store_true", help="tests/fixtures/truth only")
    parser.add_argument("--markdown", type=Path, help="write the table here too")
    parser.add_argument("--figure", type=Path, help="draw the truth of each file that runs")
    args = parser.parse_args(argv)
    files = [(p, "given") for p in args.files] or all_files(args.fixtures)
    outcomes = sweep(files)
    text = table(outcomes)
    print(text, end="")
    if args.markdown:
        args.markdown.write_text(text)
    if args.figure:
        figure(outcomes, args.figure)
    failed = [o for o in outcomes if o.status == "FAILED"]
    runs = sum(o.status == "runs" for o in outcomes)
    print(
        f"{len(outcomes)} files: {runs} run, {len(outcomes) - runs - len(failed)} refused, "
        f"{len(failed)} FAILED",
        file=sys.stderr,
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
