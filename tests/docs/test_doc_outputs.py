"""What the docs say a command prints, run as the pages write it (issue 37).

The commands, snippets and printed lines are read from the pages (README.md, docs/*.md), never
copied here, so that an edit of a page is what is tested:

- every terminal transcript of the pages (a fenced block of ``$ pasim ...`` lines, each
  followed by what it printed) is run in this process (``pasim_graph.cli.main``), in a scratch
  folder laid out as the repository is (``graphs/``, ``tests/``, and ``../shared`` where it is
  present), and its output (standard error, then standard output, as a terminal shows a run)
  compared with the lines shown: exactly, except that a line ``...`` stands for any lines, a
  ``...`` inside a line for any text, and a run's times (``wrote g.zarr in 13.8 s ...``) for
  the machine's (:mod:`.pages`);
- the other commands and snippets that state a result (the quick start, the README's Python,
  ``pasim export``'s file names, the studio's banner, the plugin guide's listing, files and
  messages, the propagation note, the truth files' messages) are run or built here and held
  to what the page states.

A run of a large sector runs once per module (the quick start's, 4-6 s of CPU); the 10 m
CPPAR's (13 s more) is ``slow``.
"""

from __future__ import annotations

import os
import re
import shlex
import sys
from contextlib import contextmanager
from importlib.metadata import EntryPoint
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pasim_graph import block, registry
from pasim_graph.graphfile import dumps, parse

from ..conftest import FIXTURES, GRAPHS, ROOT, Result, pasim_in_process
from .pages import Command, assert_shows, fence_after, transcripts

README = ROOT / "README.md"
DOCS = ROOT / "docs"
GUIDE = DOCS / "writing-blocks.md"
SHARED = ROOT.parent / "shared"
PLUGIN_PKG = ROOT / "tests" / "plugin_pkg"

#: Transcripts left to ``-m slow``, by a graph they run, with why.
SLOW = {
    "graphs/cppar10_radar.yaml": "the 10 m CPPAR over 90 beams: 13 s of CPU",
}


# --------------------------------------------------------------------------- the scratch folder


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """A folder laid out as the repository is for the pages' commands: ``graphs/``,
    ``tests/`` and ``benchmarks/`` in it, ``../shared`` beside it where the repository has
    one."""
    top = tmp_path_factory.mktemp("docs")
    repo = top / "repo"
    repo.mkdir()
    for name in ("graphs", "tests", "benchmarks"):
        (repo / name).symlink_to(ROOT / name)
    if SHARED.is_dir():
        (top / "shared").symlink_to(SHARED)
    return repo


@contextmanager
def inside(folder: Path):
    before = Path.cwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


_RUNS: dict[tuple[str, tuple[str, ...]], Result] = {}


def pasim_at(folder: Path, argv: tuple[str, ...] | list[str]) -> Result:
    """``pasim ARGV`` in this process with ``folder`` as the working folder; a command that
    writes (a run, an export) once per folder: a second would be refused, its output there."""
    assert argv[0] == "pasim", argv
    key = (str(folder), tuple(argv))
    if key in _RUNS:
        return _RUNS[key]
    with inside(folder):
        result = pasim_in_process(*argv[1:])
    if argv[1] in ("run", "export"):
        _RUNS[key] = result
    return result


def printed(result: Result) -> str:
    """What a terminal shows: the notes and progress come before the table."""
    return result.stderr + result.stdout


def commands_of(fence_text: str) -> list[list[str]]:
    """The ``pasim`` commands of a shell block, comments and continuations taken off."""
    text = fence_text.replace("\\\n", " ")
    out = []
    for line in text.splitlines():
        for part in line.split("&&"):
            words = shlex.split(part, comments=True)
            if words and words[0] == "pasim":
                out.append(words)
    return out


# ------------------------------------------------------------------------------ plugins


def entry_points_of(pyproject: str, group: str = registry.GROUP) -> dict[str, str]:
    """The entry points of ``group`` in a pyproject.toml's text (as setuptools reads them)."""
    section = re.search(
        rf'^\[project\.entry-points\."{re.escape(group)}"\]\n(.*?)(?=^\[|\Z)',
        pyproject,
        re.S | re.M,
    )
    assert section, group
    return dict(re.findall(r'^"([^"]+)"\s*=\s*"([^"]+)"', section.group(1), re.M))


def guide_package(folder: Path) -> dict[str, str]:
    """The guide's package ``my_radar_blocks`` written in ``folder`` as its "Layout" lays it
    out, its modules from the page; its block entry points from the page's pyproject.toml."""
    package = folder / "my_radar_blocks"
    package.mkdir(exist_ok=True)
    (package / "__init__.py").write_text("")
    for module in ("radome", "phase_noise"):
        code = fence_after(GUIDE, f"`my_radar_blocks/{module}.py`", "python").text
        (package / f"{module}.py").write_text(code)
    return entry_points_of(fence_after(GUIDE, "## pyproject.toml: the entry points", "toml").text)


@contextmanager
def registered(monkeypatch: pytest.MonkeyPatch, entry_points: dict[str, str], *paths: Path):
    """Block types registered as a package's entry points would register them, their
    modules found on ``paths``, in this process."""
    for path in paths:
        monkeypatch.syspath_prepend(str(path))
    real = dict(registry._entry_points())
    ours = {name: EntryPoint(name, value, registry.GROUP) for name, value in entry_points.items()}
    registry._loaded.clear()
    registry._errors.clear()
    monkeypatch.setattr(registry, "_entry_points", lambda: {**real, **ours})
    monkeypatch.setattr(block, "TYPE_NAMES", dict(block.TYPE_NAMES))
    monkeypatch.setattr(registry, "TYPE_NAMES", block.TYPE_NAMES)
    try:
        yield
    finally:
        registry._loaded.clear()  # before the real table and entry points come back
        registry._errors.clear()
        packages = {value.split(".")[0] for value in entry_points.values()}
        for name in [m for m in sys.modules if m.split(".")[0] in packages]:
            del sys.modules[name]


@pytest.fixture
def guide_plugin(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    """The guide's package installed, as far as this process sees."""
    with registered(monkeypatch, guide_package(tmp_path), tmp_path):
        yield


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    """The guide's package and ``tests/plugin_pkg`` installed (the guide's transcripts have
    both: its own blocks, and the broken plugin its failures show)."""
    example = entry_points_of((PLUGIN_PKG / "pyproject.toml").read_text())
    with registered(monkeypatch, {**guide_package(tmp_path), **example}, tmp_path, PLUGIN_PKG):
        yield


def guide_graphs(folder: Path) -> str:
    """``radome_radar.yaml`` made in ``folder`` as the guide's "Using it in a graph" makes it
    (its block added to graphs/generic_radar.yaml, the connection it names replaced by its
    two), written canonically; and ``broken.yaml``, the same with the radome of the broken
    plugin's type (the page's problems name its lines 9 and 10). Returns the canonical text."""
    page = GUIDE.read_text()
    text = (GRAPHS / "generic_radar.yaml").read_text()
    added = fence_after(GUIDE, "1. Add the block:", "yaml").text.strip()
    old = re.search(r"Replace the connection `([^`]+)` with", page).group(1)
    new = fence_after(GUIDE, "Replace the connection", "yaml").text.strip().splitlines()
    assert f"  - {old}\n" in text and "blocks:\n" in text
    text = text.replace("blocks:\n", f"blocks:\n  {added}\n")
    text = text.replace(f"  - {old}\n", "".join(f"  {line}\n" for line in new))
    canonical = dumps(parse(text))
    (folder / "radome_radar.yaml").write_text(canonical)
    broken = re.sub(r"type: radome\.attenuator\b", "type: example.broken", canonical)
    (folder / "broken.yaml").write_text(broken)
    return canonical


# --------------------------------------------------------------------------- the transcripts


def _transcript_params():
    out = []
    for commands in transcripts():
        words = [w for c in commands for w in c.argv]
        marks = [pytest.mark.slow for graph in SLOW if graph in words]
        out.append(pytest.param(commands, id=commands[0].fence.where, marks=marks))
    return out


def _placed(command: Command, folder: Path) -> tuple[list[str], list[str]]:
    """The command and its lines with a ``/tmp/`` path of the page put in ``folder``."""
    scratch = str(folder / "tmp") + "/"
    (folder / "tmp").mkdir(exist_ok=True)
    argv = [w.replace("/tmp/", scratch, 1) if w.startswith("/tmp/") else w for w in command.argv]
    shown = [line.replace(" /tmp/", " " + scratch) for line in command.shown]
    return argv, shown


def expected_code(shown: list[str]) -> int:
    """2 where the page shows a refusal (``error: ...``, ``N problems in the graph``)."""
    refused = any(re.match(r"error: |\d+ problems? in the graph", line) for line in shown)
    return 2 if refused else 0


@pytest.mark.parametrize("commands", _transcript_params())
def test_a_transcript_prints_what_the_page_shows(commands: list[Command], workdir, request):
    for command in commands:
        if any("../shared/" in w for w in command.argv) and not SHARED.is_dir():
            pytest.skip(
                f"{command.text}: ../shared (the public data beside the repository) is absent"
            )
    if commands[0].fence.page == GUIDE:
        request.getfixturevalue("plugins")
        guide_graphs(workdir)
    for command in commands:
        argv, shown = _placed(command, workdir)
        result = pasim_at(workdir, argv)
        where = f"{command.fence.where}: {command.text}"
        assert result.returncode == expected_code(shown), f"{where}\n{printed(result)}"
        assert_shows(shown, printed(result), where)


def test_every_transcript_runs_a_pasim_command():
    """The transcripts are run as ``pasim`` commands: a page's ``$ python ...`` or ``$ dask``
    would need its own test here."""
    found = transcripts()
    assert len(found) >= 6
    for commands in found:
        for command in commands:
            assert command.argv[0] == "pasim", (command.fence.where, command.text)


# --------------------------------------------------------------------------- the quick start


def quick_start() -> list[str]:
    """The README's quick-start run (the last command of its first block)."""
    return commands_of(fence_after(README, "## Quick start", "bash").text)[-1]


@pytest.fixture(scope="module")
def generic(workdir) -> Path:
    """The quick start's store, as the README makes it."""
    result = pasim_at(workdir, quick_start())
    assert result.returncode == 0, result.stderr
    return workdir / quick_start()[quick_start().index("--out") + 1]


def test_the_quick_start_prints_the_error_table_of_its_sector(generic, workdir):
    """The README: "runs the paper's generic radar ... over azimuth 240-330 deg ... prints
    the error table": a row per moment, and the rule of the scored gates."""
    text = README.read_text()
    a0, a1 = map(float, re.search(r"over azimuth\s+(\d+)-(\d+) deg", text).groups())
    out = pasim_at(workdir, quick_start()).stdout.splitlines()
    assert out[0].split() == ["moment", "bias", "std", "count", "req", "bias/std", "pass"]
    assert [line.split()[0] for line in out[1:7]] == sorted(
        ["DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"]
    )
    assert out[7].startswith("scored gates: ")
    azimuth = xr.open_datatree(generic, engine="zarr")["sweep_0"]["azimuth"].values
    assert azimuth.min() > a0 and azimuth.max() < a1 and azimuth.size == a1 - a0


def test_the_quick_starts_picture(generic, workdir):
    (argv,) = commands_of(fence_after(README, "Then look at it:", "bash").text)
    result = pasim_at(workdir, argv)
    assert result.returncode == 0, result.stderr
    png = workdir / argv[argv.index("--out") + 1]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _numbers(text: str) -> list[int]:
    return [int(n.replace(",", "")) for n in re.findall(r"\d[\d,]*\d|\d", text)]


@pytest.mark.parametrize("page", [README, DOCS / "physics.md"], ids=lambda p: p.name)
def test_the_censoring_counts_of_the_quick_start(page, generic, workdir):
    """The page: "of the sector's 164,880 gates, none whose expected echo is more than 10 dB
    below the noise is reported (53,466 are without censoring)": the quick start's store, and
    the same run with DBZH's threshold off (``null``; ``--outputs DBZH`` gives the same
    DBZH)."""
    words = " ".join(page.read_text().split())
    claim = re.search(
        r"([\d,]+) gates\)?,? no(?:ne| gate) whose expected echo is more than "
        r"(\d+) dB below the noise is reported;? \(?(?:([\d,]+) are without "
        r"censoring|without censoring ([\d,]+)\s+are)",
        words,
    )
    assert claim, page
    gates, below_db = _numbers(claim.group(1))[0], int(claim.group(2))
    uncensored = _numbers(claim.group(3) or claim.group(4))[0]
    sweep = xr.open_datatree(generic, engine="zarr")["sweep_0"].to_dataset()
    assert sweep["DBZH"].size == gates
    weak = sweep["SNRH"].values < -below_db
    assert not np.isfinite(sweep["DBZH"].values[weak]).any()
    off = [*quick_start()[:-1], "uncensored.zarr", "--outputs", "DBZH"]
    off += ["--set", "ppp.snr_threshold_reflectivity_db=null"]
    result = pasim_at(workdir, off)
    assert result.returncode == 0, result.stderr
    dbzh = xr.open_datatree(workdir / "uncensored.zarr", engine="zarr")["sweep_0"]["DBZH"]
    assert int(np.isfinite(dbzh.values[weak]).sum()) == uncensored


def test_the_readmes_python_reads_the_quick_starts_store(generic, workdir):
    """The README's Python, run in the folder of the quick start: a sweep of azimuth x range
    with the fields it names, every gate georeferenced, a Py-ART radar."""
    code = fence_after(README, "## What a run gives you", "python").text
    assert '"generic.zarr"' in code and generic.name == "generic.zarr"
    names: dict = {}
    with inside(workdir):
        exec(compile(code, f"{README}:python", "exec"), names)
    assert names["sweep"]["DBZH"].dims == ("azimuth", "range")  # "# azimuth x range"
    georeferenced = names["tree"]["sweep_0"].to_dataset()
    assert {"x", "y", "z"} <= set(georeferenced.coords)
    # "# Py-ART's radar (pyart.xradar.Xradar): pyart.graph.RadarDisplay(radar).plot("DBZH")"
    kind, use = re.search(r"# Py-ART's radar \(([\w.]+)\): (.+)$", code, re.M).groups()
    radar = names["radar"]
    assert f"{type(radar).__module__}.{type(radar).__name__}".startswith(kind.rsplit(".", 1)[0])
    assert type(radar).__name__ == kind.rsplit(".", 1)[1] and "DBZH" in radar.fields
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    exec(use, names)
    plt.close("all")


def test_the_readmes_score_json_has_the_keys_it_names(generic, workdir):
    import json

    words = " ".join(README.read_text().split())
    sentence = re.search(r"`--json` prints an object keyed by moment, each with (.*?)\. ", words)
    keys = set(re.findall(r"`(\w+)`", sentence.group(1)))
    assert len(keys) == 6
    result = pasim_at(workdir, ["pasim", "score", generic.name, "--json"])
    assert result.returncode == 0, result.stderr
    scores = json.loads(result.stdout)
    for moment in ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH"):
        assert keys <= set(scores[moment]), moment


def test_pasim_export_writes_the_files_the_page_names(generic, workdir):
    """docs/export.md: its run is the quick start's; each export writes the file its comment
    or ``--out`` names, and without ``--out`` the store's name with the format's."""
    export = DOCS / "export.md"
    commands = commands_of(fence_after(export, "# Export for other tools", "bash").text)
    assert commands[0] == quick_start()
    block = fence_after(export, "# Export for other tools", "bash").text
    named = dict(re.findall(r"--format (\w+)\s+# (\S+)", block))
    for argv in commands[1:]:
        result = pasim_at(workdir, argv)
        assert result.returncode == 0, result.stderr
        fmt = argv[argv.index("--format") + 1]
        out = argv[argv.index("--out") + 1] if "--out" in argv else named[fmt]
        assert (workdir / out).is_file(), (argv, result.stderr)
        assert result.stderr.startswith(f"wrote {out}: "), result.stderr
    store, default = re.search(r"\(`(\w+\.zarr)` -> `([\w.]+)`\)", export.read_text()).groups()
    assert store == generic.name
    result = pasim_at(workdir, ["pasim", "export", store, "--format", "odim"])
    assert result.returncode == 0 and (workdir / default).is_file(), result.stderr


def test_the_scaling_guides_task_record_snippet(workdir):
    """docs/scaling.md's snippet reads the record of the store it names (the run of
    docs/physics.md's transcript writes ``g.zarr``): one task a chunk of that run, each with
    its start and stop, and a busy time of more than nothing and under a minute a chunk."""
    code = fence_after(DOCS / "scaling.md", "Times are seconds from", "python").text
    store = re.search(r'read_tasks\("([^"]+)"\)', code).group(1)
    physics = next(c for t in transcripts() for c in t if c.fence.page.name == "physics.md")
    assert physics.argv[-1] == store
    assert pasim_at(workdir, physics.argv).returncode == 0
    names: dict = {}
    with inside(workdir):
        exec(compile(code, "scaling.md:python", "exec"), names)
    chunks = int(re.search(r"(\d+) of \1 chunks", " ".join(physics.shown)).group(1))
    assert len(names["run"]["tasks"]) == chunks  # "12 of 12 chunks in 8.7 s"
    assert 0 < names["busy"] < chunks * 60


# --------------------------------------------------------------------------- the studio


@pytest.mark.parametrize("page", ["docs/studio.md", "README.md"])
def test_the_studios_banner(page, workdir, monkeypatch, capsys):
    """``pasim studio`` prints what docs/studio.md shows (the folder served, the runs' folder,
    the address) and the address the README's comment gives; the page's paths, token and
    runs folder are examples, and the port is any free one here (8765, the default, may be
    taken: the default is checked from the parser)."""
    from pasim_graph.cli import main, parser
    from pasim_graph.studio.server import StudioServer

    monkeypatch.setattr(StudioServer, "serve_forever", lambda self, *a, **k: None)
    if page == "README.md":
        (argv,) = commands_of(fence_after(README, "## The studio", "bash").text)
        claimed = re.search(r"# prints (\S+);", fence_after(README, "## The studio").text).group(1)
        shown = [claimed]
    else:
        argv = commands_of(fence_after(DOCS / "studio.md", "# The studio", "bash").text)[-1]
        shown = fence_after(DOCS / "studio.md", "open this one first").text.splitlines()
    assert parser(["studio"]).parse_args(["studio"]).port == 8765
    with inside(workdir):
        assert main([*argv[1:], "--port", "0"]) == 0
    out = capsys.readouterr().out
    port = re.search(r"http://127\.0\.0\.1:(\d+)/", out).group(1)
    served = (workdir / argv[2]).resolve()
    served = served.parent if served.is_file() else served
    actual = out.replace(f":{port}/", ":8765/").replace(str(served), "FOLDER")
    actual = re.sub(r"\S*/pasim-studio-runs-\w+", "RUNS", actual)
    actual = re.sub(r"token=[\w-]+", "token=TOKEN", actual)
    wanted = []
    for line in shown:
        line = re.sub(r"/\S+/graphs\b", "FOLDER", line)
        line = re.sub(r"\S*/pasim-studio-runs-\w+", "RUNS", line)
        wanted.append(re.sub(r"token=\w*\.\.\.", "token=TOKEN", line))
    if page == "README.md":
        urls = [line.strip() for line in actual.splitlines() if line.strip().startswith("http")]
        assert urls == wanted
    else:
        assert_shows(wanted, actual, page)


# --------------------------------------------------------------------------- the plugin guide


def test_the_guides_own_tests_pass(tmp_path):
    """The guide's "Testing it": its ``tests/test_blocks.py``, run against its package."""
    import importlib

    guide_package(tmp_path)
    code = fence_after(GUIDE, "`tests/test_blocks.py`:", "python").text
    (tmp_path / "guide_test_blocks.py").write_text(code)
    sys.path.insert(0, str(tmp_path))
    try:
        module = importlib.import_module("guide_test_blocks")
        tests = [getattr(module, n) for n in dir(module) if n.startswith("test_")]
        assert len(tests) == code.count("\ndef test_") >= 3
        for test in tests:
            test()
    finally:
        sys.path.remove(str(tmp_path))
        for name in [
            m for m in sys.modules if m.split(".")[0] in ("my_radar_blocks", "guide_test_blocks")
        ]:
            del sys.modules[name]


def test_the_guides_listing_of_its_blocks(guide_plugin, workdir):
    """The guide's "Installing and listing it": ``pasim blocks`` with its package installed."""
    (argv,) = commands_of(fence_after(GUIDE, "## Installing and listing it", "bash").text)
    shown = fence_after(GUIDE, "## Installing and listing it", "").text.splitlines()
    result = pasim_at(workdir, argv)
    assert result.returncode == 0
    assert_shows(shown, printed(result), f"{GUIDE.name}: {shlex.join(argv)}")


def test_the_guides_graph_in_canonical_order(tmp_path):
    """The guide's "Written in canonical order ..., the changed parts of the file are": every
    line shown is the canonical file's, in order, ``...`` for the lines left out."""
    canonical = guide_graphs(tmp_path)
    shown = fence_after(GUIDE, "the changed parts of the file", "yaml").text.splitlines()
    shown = [line if line.strip() != "..." else "..." for line in shown]
    assert_shows(["...", *shown, "..."], canonical, GUIDE.name)


def test_the_guides_counts_of_blocks_and_connections(guide_plugin, tmp_path):
    """The guide's "valid (11 blocks, 22 connections)", counted in the graph the guide makes."""
    from pasim_graph import load

    guide_graphs(tmp_path)
    match = re.search(
        r"radome_radar\.yaml: valid \((\d+) blocks, (\d+) connections\)", GUIDE.read_text()
    )
    graph = load(tmp_path / "radome_radar.yaml")
    assert (len(graph.classes), len(graph.edges)) == tuple(map(int, match.groups()))


def test_the_guides_radome_lowers_dbzh_by_its_loss(plugins, workdir):
    """The guide: "Against a run of the plain generic radar over the same sector and seed, the
    median DBZH change where the expected SNR is above 40 dB was -10.00 dB": the guide's own
    run (its transcript) against the generic radar's; and the scored gates its loss censors."""
    run = next(c for t in transcripts() for c in t if "radome.loss_db=10" in " ".join(c.argv))
    guide_graphs(workdir)
    assert pasim_at(workdir, run.argv).returncode == 0
    sector = run.argv[run.argv.index("--sector") + 1]
    plain = ["pasim", "run", "graphs/generic_radar.yaml", "--sector", sector, "--out", "plain.zarr"]
    assert pasim_at(workdir, plain).returncode == 0
    words = " ".join(GUIDE.read_text().split())
    snr, change = re.search(
        r"the median DBZH change where the expected SNR is above (\d+) dB was (-?[\d.]+) dB", words
    ).groups()
    a = xr.open_datatree(workdir / run.argv[-1], engine="zarr")["sweep_0"].to_dataset()
    b = xr.open_datatree(workdir / "plain.zarr", engine="zarr")["sweep_0"].to_dataset()
    strong = (b["SNRH"].values > float(snr)) & np.isfinite(a["DBZH"].values)
    median = np.median(a["DBZH"].values[strong] - b["DBZH"].values[strong])
    assert f"{median:.2f}" == change
    # "The 10 dB of SNR lost censor 55 of the scored gates": the plain run loses none.
    lost = int(re.search(r"SNR lost censor (\d+) of the scored gates", words).group(1))
    assert f"DBZH: {lost} of " in pasim_at(workdir, run.argv).stdout
    assert "have no estimate" not in pasim_at(workdir, plain).stdout


def test_the_guides_square_array_figures():
    """The guide: "4.23 deg beamwidth and a -13.2 dB first sidelobe for N = 24, as the array factor
    gives": the array factor's (tests/engine/test_plugin_antenna.py holds ``pasim pattern``
    of the guide's class to the same)."""
    from ..engine import test_plugin_antenna as antenna

    words = " ".join(GUIDE.read_text().split())
    width, sidelobe, n = re.search(
        r"\(([\d.]+) deg beamwidth and a (-[\d.]+) dB first sidelobe for N = (\d+)", words
    ).groups()
    assert int(n) == antenna.N
    assert f"{antenna.beamwidth_deg():.2f}" == width
    assert f"{antenna.first_sidelobe_db():.1f}" == sidelobe


def test_the_guides_antenna_without_a_method(monkeypatch, tmp_path, capsys):
    """The guide's square array with ``pattern_gain_db`` left out, registered as its page
    registers it: the warning line the page shows."""
    from pasim_graph.cli import main

    shown = fence_after(GUIDE, "A class that leaves one of the four methods out").text.strip()
    name, value = re.search(r"block plugin '([^']+)' \(([^)]+)\)", shown).groups()
    code = fence_after(GUIDE, "`my_radar_blocks/square_array.py`", "python").text
    code = re.sub(r"\n    def pattern_gain_db\(.*?\n(?=    def )", "\n", code, flags=re.S)
    assert "pattern_gain_db" not in code
    package = tmp_path / "my_radar_blocks"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "square_array.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    real = dict(registry._entry_points())
    registry._loaded.clear()
    registry._errors.clear()
    monkeypatch.setattr(
        registry, "_entry_points", lambda: {**real, name: EntryPoint(name, value, registry.GROUP)}
    )
    try:
        graph = (GRAPHS / "generic_radar.yaml").read_text().replace("antenna.pencil", name)
        (tmp_path / "square.yaml").write_text(graph)
        assert main(["validate", str(tmp_path / "square.yaml")]) == 2
        assert shown in capsys.readouterr().err.splitlines()
    finally:
        registry._loaded.clear()
        registry._errors.clear()
        for module in [m for m in sys.modules if m.split(".")[0] == "my_radar_blocks"]:
            del sys.modules[module]


def test_the_guides_command_without_run(monkeypatch, tmp_path):
    """The guide's ``count`` command without its ``run``, registered as its pyproject.toml
    registers it: the warning the page quotes."""
    words = " ".join(GUIDE.read_text().split())
    quoted = re.search(r"\(`(command plugin '[^`]+)`\)", words).group(1)
    code = fence_after(GUIDE, "add_graph_arguments", "python").text
    code = re.sub(r"\n    def run\(.*?\n(?=\n\S)", "\n", code, flags=re.S)
    assert "def run" not in code and "def configure" in code
    package = tmp_path / "my_radar_blocks"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "count.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    toml = fence_after(GUIDE, "COMMAND = CountCommand()", "toml").text
    ours = [
        EntryPoint(n, v, registry.COMMANDS)
        for n, v in entry_points_of(toml, registry.COMMANDS).items()
    ]
    real = registry.entry_points
    monkeypatch.setattr(
        registry,
        "entry_points",
        lambda group: [*real(group=group), *(ours if group == registry.COMMANDS else [])],
    )
    registry.commands.cache_clear()
    try:
        with pytest.warns(registry.PluginWarning) as caught:
            assert "count" not in registry.commands()
        pattern = re.escape(quoted).replace(re.escape("..."), ".*")
        assert any(re.fullmatch(pattern, str(w.message)) for w in caught), [
            str(w.message) for w in caught
        ]
    finally:
        registry.commands.cache_clear()
        for module in [m for m in sys.modules if m.split(".")[0] == "my_radar_blocks"]:
            del sys.modules[module]


# --------------------------------------------------------------------------- notes and messages


def test_the_propagation_note():
    """docs/propagation.md's note is what the C-band graph's weather channel says."""
    import warnings

    from pasim_blocks.propagation.path import note

    from pasim_graph import load

    shown = fence_after(DOCS / "propagation.md", "When it is on, the run").text.strip()
    graph = load(GRAPHS / "cppar10_cband.yaml")
    params = {name: graph.value("weather", name) for name in graph.classes["weather"].params}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        note(params)
    assert [f"note: {w.message}" for w in caught] == [shown]


@pytest.fixture(scope="module")
def odd_file(tmp_path_factory) -> Path:
    """docs/algorithms.md's ``odd.nc``: a CfRadial 1 file of a 1.00 deg sweep whose fields are
    ``DBZ_QC`` and ``V_QC`` (the ODIM sample's, renamed)."""
    import warnings

    import xradar

    folder = tmp_path_factory.mktemp("odd")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = xradar.io.open_odim_datatree(
            str(FIXTURES / "truth" / "T_PAZD63_C_LFPW_20230420065331.h5")
        )
        sweep = tree["sweep_0"].to_dataset()
        sweep = sweep.drop_vars("TH").rename({"DBZH": "DBZ_QC", "VRADH": "V_QC"})
        for name in ("DBZ_QC", "V_QC"):
            sweep[name].attrs.pop("standard_name", None)
        tree["sweep_0"] = sweep
        xradar.io.to_cfradial1(tree, folder / "odd.nc")
    (folder / "graphs").symlink_to(GRAPHS)
    return folder / "odd.nc"


def test_the_truth_files_messages(odd_file, tmp_path):
    """docs/algorithms.md's refusals of ``odd.nc`` (a name it lacks; no reflectivity known by
    name) and its note on the ARM file of tests/fixtures/truth (no polarimetric fields), each
    line as a run prints it."""
    page = DOCS / "algorithms.md"
    lacks = fence_after(page, "a name it\nlacks is refused").text.splitlines()
    unknown, single = fence_after(page, "and were no alias\neither").text.splitlines()
    named = re.search(r"fields maps (\w+) to '(\w+)'", lacks[0]).groups()
    folder = odd_file.parent
    run = ["pasim", "run", "graphs/generic_radar.yaml", "--truth", odd_file.name]
    run += ["--set", "truth.elevation_deg=1.0", "--sector", "102:104"]
    result = pasim_at(
        folder, [*run, "--set", f"truth.fields={{{named[0]}: {named[1]}}}", "--out", "a.zarr"]
    )
    assert result.returncode == 2
    assert_shows(["...", *lacks], printed(result), f"{page.name}: a name odd.nc lacks")
    result = pasim_at(folder, [*run, "--out", "b.zarr"])
    assert result.returncode == 2
    assert_shows(["...", unknown], printed(result), f"{page.name}: odd.nc without a known name")
    arm = re.search(r"note: truth (\S+):", single).group(1)
    (tmp_path / arm).symlink_to(FIXTURES / "truth" / arm)
    (tmp_path / "graphs").symlink_to(GRAPHS)
    argv = ["pasim", "run", "graphs/generic_radar.yaml", "--truth", arm, "--sector", "0:1"]
    argv += ["--set", "weather.method=expected", "--out", "c.zarr"]
    result = pasim_at(tmp_path, argv)
    assert single in printed(result).splitlines(), printed(result)


# --------------------------------------------------------------------------- read off the tables


def _shown_table(page: Path, command: str) -> dict[str, list[float]]:
    """The score table a page's transcript shows for ``command``: bias, std and count by
    moment (the transcript's test holds the table to the code's)."""
    found = next(c for t in transcripts() for c in t if c.fence.page == page and c.text == command)
    rows = [line.split() for line in found.shown]
    moments = ("DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH")
    return {r[0]: [float(r[1]), float(r[2]), float(r[3])] for r in rows if r and r[0] in moments}


PHYSICS_RUN = "pasim run graphs/generic_radar.yaml --sector 240:330 --out g.zarr"


def test_the_physics_pages_words_on_its_table():
    """What docs/physics.md reads off its table: the ratios to the paper's standard
    deviations, and the gates without dual-pol or velocity truth."""
    page = DOCS / "physics.md"
    words = " ".join(page.read_text().split())
    table = _shown_table(page, PHYSICS_RUN)
    paper = re.search(
        r"standard deviations of ([\d.]+) dB for Z, ([\d.]+) dB for ZDR, ([\d.]+) for ρhv and "
        r"([\d.]+)° for Φ_DP\. Ours are about ([\d.]+), ([\d.]+), ([\d.]+) and ([\d.]+) times "
        r"larger",
        words,
    ).groups()
    for moment, theirs, ratio in zip(
        ("DBZH", "ZDR", "RHOHV", "PHIDP"), paper[:4], paper[4:], strict=True
    ):
        assert f"{table[moment][1] / float(theirs):.1f}" == ratio, moment
    no_dual, no_doppler = re.search(
        r"([\d,]+) scored gates have DBZH but no dual-pol truth, and ([\d,]+) have no velocity",
        words,
    ).groups()
    assert table["DBZH"][2] - table["ZDR"][2] == _numbers(no_dual)[0]
    assert table["DBZH"][2] - table["VRADH"][2] == _numbers(no_doppler)[0]


@pytest.mark.slow  # a second run of the quick start's sector: 4-5 s of CPU
def test_the_physics_pages_other_seed(workdir):
    """docs/physics.md: "With `--seed 1` the standard deviations were 2.08 dB for DBZH, ...":
    the run of the page's transcript with ``--seed 1``, each at the page's precision."""
    page = DOCS / "physics.md"
    words = " ".join(page.read_text().split())
    stated = re.search(
        r"With `--seed (\d+)` the standard deviations were ([\d.]+) dB for DBZH, ([\d.]+) dB for "
        r"ZDR, ([\d.]+) for ρhv and ([\d.]+)° for Φ_DP",
        words,
    ).groups()
    argv = [*shlex.split(PHYSICS_RUN)[:-1], "g_seed.zarr", "--seed", stated[0]]
    result = pasim_at(workdir, argv)
    assert result.returncode == 0, result.stderr
    rows = {r.split()[0]: r.split() for r in result.stdout.splitlines()[1:7]}
    for moment, value in zip(("DBZH", "ZDR", "RHOHV", "PHIDP"), stated[1:], strict=True):
        decimals = len(value.split(".")[1])
        assert f"{float(rows[moment][2]):.{decimals}f}" == value, moment
