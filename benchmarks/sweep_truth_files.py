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

    def row(self) -> str:
        if self.status == "runs":
            found = ", ".join(
                f"{m} ({self.moments[m]}, {self.scored.get(m, 0)} gates)"
                for m in MOMENTS
                if m in self.moments
            )
            result = f"runs: {found}"
        else:
            result = f"{self.status}: {self.message}"
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
    """moment -> gates scored against the truth, for each moment with a truth in the store
    (what ``pasim score`` counts: the finite ``error_<moment>`` values)."""
    import xarray as xr

    sweep = xr.open_zarr(store, group="sweep_0")
    return {
        m: int(np.isfinite(sweep[f"error_{m}"].values).sum())
        for m in MOMENTS
        if f"truth_{m}" in sweep and np.isfinite(sweep[f"truth_{m}"].values).any()
    }


def _short(line: str, path: Path) -> str:
    """A message with the file's folder left out (the table names the file)."""
    return line.replace(str(path.parent) + "/", "").replace("|", "/").strip()


def sweep(files: list[tuple[Path, str]]) -> list[Outcome]:
    with tempfile.TemporaryDirectory(prefix="pasim-sweep-") as work:
        return [sweep_file(p, source, Path(work)) for p, source in files]


def table(outcomes: list[Outcome]) -> str:
    head = "| File | From | Format | Run | Result: moments (the file's field, gates scored) |"
    rule = "|---|---|---|---|---|"
    return "\n".join([head, rule, *(o.row() for o in outcomes)]) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="files to sweep (default: all)")
    parser.add_argument("--fixtures", action="store_true", help="tests/fixtures/truth only")
    parser.add_argument("--markdown", type=Path, help="write the table here too")
    args = parser.parse_args(argv)
    files = [(p, "given") for p in args.files] or all_files(args.fixtures)
    outcomes = sweep(files)
    text = table(outcomes)
    print(text, end="")
    if args.markdown:
        args.markdown.write_text(text)
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
