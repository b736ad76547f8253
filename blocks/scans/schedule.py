"""A scheduled scan: any list of beams read from a CSV file (a phased array's adaptive or
multifunction timeline), grouped into sweeps."""

from __future__ import annotations

import csv
import functools
import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from pasim_graph import Chunk, Param
from pasim_graph.fm301 import SWEEP_MODE_STEERED

from .beam_geometry import beam_dataset, seconds, site_and_start
from .scan import Scan

#: The columns a schedule file must have, and the optional one that names each beam's sweep.
COLUMNS = ("azimuth_deg", "elevation_deg", "pulses", "prt_s")
SWEEP_COLUMN = "sweep"
_BOUNDS = {
    "azimuth_deg": (0.0, 360.0, "deg"),
    "elevation_deg": (-2.0, 90.0, "deg"),
    "pulses": (2, 4096, ""),
    "prt_s": (1e-5, 0.1, "s"),
}
_SHOWN = 12  # problems listed before "and N more"
#: Lines a schedule file may hold (a beam a line): a hemisphere in 0.25 deg steps is 520,000
#: beams. Counted before the file is parsed (10 million rows took 2.9 GB as parsed rows).
MAX_LINES = 1_000_000


def _count_lines(path: str, cap: int) -> int:
    """Lines of the file, counted in blocks until more than ``cap``."""
    count = 0
    with open(path, "rb") as f:
        while block := f.read(1 << 22):
            count += block.count(b"\n")
            if count > cap:
                break
    return count


@dataclass(frozen=True)
class Schedule:
    """The beams of a schedule file in timeline order, and the sweeps they are grouped in."""

    azimuth: np.ndarray
    elevation: np.ndarray
    pulses: np.ndarray
    prt: np.ndarray
    #: Start of each beam's dwell after the schedule's start (s), in file order.
    offset: np.ndarray
    #: Rows (indices into the arrays above) of each sweep, in order of first appearance.
    sweeps: tuple[np.ndarray, ...]

    @property
    def duration(self) -> float:
        return float(self.offset[-1] + self.pulses[-1] * self.prt[-1])


def read_schedule(path: str) -> tuple[Schedule | None, list[str]]:
    """The schedule in ``path`` and every problem with it (each naming the file, the row (its
    line in the file) and the column); None when there are problems."""
    try:
        stat = os.stat(path)
    except OSError as exc:
        return None, [f"{path}: cannot be read ({exc.strerror or exc})"]
    return _read(path, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)
def _read(path: str, mtime_ns: int, size: int) -> tuple[Schedule | None, list[str]]:
    try:
        n_lines = _count_lines(path, MAX_LINES)
        if n_lines > MAX_LINES:
            return None, [
                f"{path}: holds more than {MAX_LINES:,} lines ({size / 2**20:.0f} MiB); a "
                f"schedule has at most {MAX_LINES:,} beams (refused before reading)"
            ]
        # utf-8-sig: a byte-order mark, as spreadsheets write one, is not part of the header
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        return None, [f"{path}: cannot be read as CSV ({exc})"]
    rows = [r for r in rows if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        return None, [f"{path}: empty; expected a header with {', '.join(COLUMNS)}"]
    header = [c.strip() for c in rows[0]]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        return None, [
            f"{path}: row 1 (the header): missing column(s) {', '.join(missing)}; "
            f"expected {', '.join(COLUMNS)} (and optionally {SWEEP_COLUMN})"
        ]
    twice = sorted({c for c in header if c and header.count(c) > 1})
    if twice:
        return None, [
            f"{path}: row 1 (the header): column {twice[0]!r} appears "
            f"{header.count(twice[0])} times; give each column once"
        ]
    if len(rows) == 1:
        return None, [f"{path}: holds a header and no beam"]
    at = {c: header.index(c) for c in header}
    problems: list[str] = []
    values: dict[str, list[float]] = {c: [] for c in COLUMNS}
    labels: list[str] = []
    for line, row in enumerate(rows[1:], start=2):
        for col in COLUMNS:
            text = row[at[col]].strip() if at[col] < len(row) else ""
            where = f"{path}: row {line}, column {col!r}"
            try:
                value = float(text)
            except ValueError:
                problems.append(f"{where}: expected a number, found {text!r}")
                continue
            lo, hi, unit = _BOUNDS[col]
            if col == "pulses" and value != int(value):
                problems.append(f"{where}: expected a whole number of pulses, found {text}")
            elif not (math.isfinite(value) and lo <= value <= hi):
                problems.append(f"{where}: {text} is outside {lo:g} to {hi:g} {unit}".rstrip())
            values[col].append(value)
        if SWEEP_COLUMN in at:
            labels.append(row[at[SWEEP_COLUMN]].strip() if at[SWEEP_COLUMN] < len(row) else "")
    if problems:
        return None, problems
    pulses = np.asarray(values["pulses"], dtype=np.int64)
    prt = np.asarray(values["prt_s"], dtype=np.float64)
    keys = labels if labels else [f"{m} {t!r}" for m, t in zip(pulses, prt, strict=True)]
    order: dict[str, list[int]] = {}
    for i, key in enumerate(keys):
        order.setdefault(key, []).append(i)
    for key, members in order.items():
        if len({(int(pulses[i]), float(prt[i])) for i in members}) > 1:
            lines = ", ".join(str(i + 2) for i in members[:6])
            problems.append(
                f"{path}: sweep {key!r} (rows {lines}...) mixes pulse counts or PRTs; a sweep "
                "dwells alike on all its beams: give its beams one pulses and prt_s, or put "
                "them in sweeps of their own"
            )
    if problems:
        return None, problems
    dwell = pulses * prt
    return Schedule(
        azimuth=np.asarray(values["azimuth_deg"]) % 360.0,
        elevation=np.asarray(values["elevation_deg"]),
        pulses=pulses,
        prt=prt,
        offset=np.concatenate([[0.0], np.cumsum(dwell)[:-1]]),
        sweeps=tuple(np.asarray(m) for m in order.values()),
    ), []


class ScheduledScan(Scan):
    """Beams listed in a CSV file, in the order the radar forms them: a phased array's
    adaptive or multifunction timeline.

    Columns (header row first; ``#`` starts a comment line): ``azimuth_deg`` (0 to 360),
    ``elevation_deg`` (-2 to 90), ``pulses`` (2 to 4096), ``prt_s`` (1e-5 to 0.1 s), and
    optionally ``sweep``, a label per beam. Beams are grouped into sweeps (``sweep_0`` ... in
    the store, numbered in order of first appearance) by their ``sweep`` label, or without
    that column by equal (pulses, PRT); a sweep's beams must share pulses and PRT. Each beam's
    dwell starts when the one before it in the file ends, so the beams of different sweeps
    interleave in time as the timeline does. The sweeps' FM-301 mode is
    ``electronic_steering`` and their fixed angle the median elevation of their beams.
    A bad file (missing column, non-number, angle out of range) is refused at validation,
    naming the file, the row and the column.
    """

    path = Param(None, type="path", doc="schedule CSV: azimuth_deg, elevation_deg, pulses, prt_s")
    sweep_index = Param(
        0, type="int", min=0, max=100000, doc="which sweep of the schedule (set per sweep)"
    )

    @classmethod
    def check_config(cls, params: dict[str, Any], connected: set[str]) -> list[tuple[str, str]]:
        path = params.get("path")
        if not path or not os.path.isfile(path):
            return []  # the parameter's own check names a missing file
        _, problems = read_schedule(str(path))
        shown = problems[:_SHOWN]
        if len(problems) > _SHOWN:
            shown.append(f"and {len(problems) - _SHOWN} more problem(s) in {path}")
        return [("parameter 'path'", p) for p in shown]

    @classmethod
    def scan_sweeps(cls, params: dict[str, Any]) -> list[dict[str, Any]]:
        schedule, problems = read_schedule(str(params.get("path")))
        if schedule is None:
            raise ValueError("; ".join(problems[:3]))
        return [{"sweep_index": k} for k in range(len(schedule.sweeps))]

    def setup(self) -> None:
        super().setup()
        schedule, problems = read_schedule(str(self.p["path"]))
        if schedule is None:
            raise ValueError("; ".join(problems[:3]))
        k = int(self.p["sweep_index"])
        if k >= len(schedule.sweeps):
            raise ValueError(f"{self.p['path']} holds {len(schedule.sweeps)} sweep(s), not {k + 1}")
        self.rows = schedule.sweeps[k]
        self.schedule = schedule

    def beam_count(self) -> int:
        return int(self.rows.size)

    def process(self, inputs: dict[str, Any], chunk: Chunk) -> dict[str, Any]:
        s, rows = self.schedule, self.rows[chunk.beams]
        start, site = site_and_start(inputs, 0.0)
        return {
            "beams": beam_dataset(
                self._cf,
                azimuth=s.azimuth[rows],
                elevation=s.elevation[rows],
                time=start + (s.offset[rows] * 1e9).astype("timedelta64[ns]"),
                prt=s.prt[rows],
                pulses=int(s.pulses[self.rows[0]]),
                scan_rate=None,
                sweep_mode=SWEEP_MODE_STEERED,
                fixed_angle=float(np.median(s.elevation[self.rows])),
                start=start,
                end=start + seconds(s.duration),
                site=site,
            )
        }
