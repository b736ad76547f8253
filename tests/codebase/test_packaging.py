"""Packaging: a wheel built from the repository holds every package, installs in a fresh
environment and works there (every entry point loads, the quick start runs); declared
dependencies match what runtime code imports; ``pasim --version`` imports no plugin."""

from __future__ import annotations

import ast
import json
import os
import site
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[2]
PIP = [sys.executable, "-m", "pip"]


def test_version_imports_no_plugin_and_no_xarray() -> None:
    code = (
        "import sys\nfrom pasim_graph.cli import main\n"
        "try:\n    main(['--version'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pasim_blocks', 'xarray')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout
    # ... while a plugin command still parses (it loads its plugin then).
    help_text = subprocess.run(
        [sys.executable, "-m", "pasim_graph", "waveform", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert help_text.returncode == 0 and "waveform" in help_text.stdout, help_text.stderr


def runtime_imports() -> set[str]:
    found = set()
    for folder in (ROOT / "pasim_graph", ROOT / "blocks"):
        for path in folder.rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    found |= {a.name.split(".")[0] for a in node.names}
                elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                    found.add(node.module.split(".")[0])
    return found


def test_runtime_dependencies_are_what_runtime_code_imports() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = {d.split(">")[0].split("[")[0].split("=")[0].strip() for d in meta["dependencies"]}
    imported = runtime_imports()
    assert "psutil" in imported and "psutil" in declared
    # Py-ART is a runtime dependency since the algorithm blocks run its algorithms
    assert "pyart" in imported and "arm-pyart" in declared


@pytest.fixture(scope="module")
def fresh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh environment with only the built wheel installed (dependencies are reused from
    this environment through a .pth file, so nothing is downloaded)."""
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            *PIP,
            "wheel",
            str(ROOT),
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp / "dist"),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    (wheel,) = (tmp / "dist").glob("*.whl")
    env = tmp / "env"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env)], check=True)
    python = env / "bin" / "python"
    (fresh_site,) = (
        Path(
            subprocess.run(
                [python, "-c", "import site; print(site.getsitepackages()[0])"],
                check=True,
                capture_output=True,
                text=True,
            ).stdout.strip()
        )
        .parents[0]
        .glob("site-packages")
    )
    # Dependencies from this environment; its own (editable) pasim-graph is not activated
    # there, since .pth files in a directory added by a .pth line are not run.
    (fresh_site / "zz_dependencies.pth").write_text(site.getsitepackages()[0] + "\n")
    subprocess.run(
        [*PIP, "--python", str(python), "install", "--no-deps", "--no-index", "-q", str(wheel)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    return env


def run_fresh(env: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    return subprocess.run(
        list(args), capture_output=True, text=True, timeout=300, cwd=cwd, env=clean
    )


def test_wheel_installs_and_every_entry_point_loads_from_it(fresh: Path, tmp_path: Path) -> None:
    code = (
        "import importlib.metadata as md, json, pasim_blocks, pasim_graph\n"
        "eps = [e for g in ('pasim_graph.blocks', 'pasim_graph.commands',\n"
        "                          'pasim_graph.figures')\n"
        "       for e in md.entry_points(group=g)]\n"
        "loaded = {e.name: e.load().__module__ for e in eps}\n"
        "print(json.dumps({'blocks': pasim_blocks.__file__, 'graph': pasim_graph.__file__,\n"
        "                  'loaded': loaded}))\n"
    )
    out = run_fresh(fresh, str(fresh / "bin" / "python"), "-c", code, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    info = json.loads(out.stdout)
    for key in ("blocks", "graph"):
        assert str(fresh) in info[key], info[key]  # the wheel's copy, not the repository's
    source = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    expected = {*source["pasim_graph.blocks"], *source["pasim_graph.commands"]}
    expected |= set(source["pasim_graph.figures"])
    assert set(info["loaded"]) == expected
    listing = run_fresh(fresh, str(fresh / "bin" / "pasim"), "blocks", "--json", cwd=tmp_path)
    assert listing.returncode == 0, listing.stderr
    assert {b["type"] for b in json.loads(listing.stdout)} == set(source["pasim_graph.blocks"])


def test_quick_start_runs_from_the_wheel(fresh: Path, tmp_path: Path) -> None:
    graph = ROOT / "graphs" / "generic_radar.yaml"
    out = run_fresh(
        fresh,
        str(fresh / "bin" / "pasim"),
        "run",
        str(graph),
        "--sector",
        "280:284",
        "--out",
        str(tmp_path / "quick.zarr"),
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "DBZH" in out.stdout + out.stderr
