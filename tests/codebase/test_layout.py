"""The block library's layout: its packages import without warnings, each says what it holds,
and the wheel's package list is found, not typed. (The flat import paths of before the
packages were removed: no release ever had them.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_new_paths_import_without_warnings() -> None:
    code = (
        "import warnings\nwarnings.simplefilter('error')\n"
        "import pasim_blocks.weather.channel, pasim_blocks.truth.nexrad\n"
        "import pasim_blocks.antennas.planar\n"
        "from pasim_blocks.weather import cells\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def test_every_subpackage_has_a_docstring() -> None:
    for init in (ROOT / "blocks").rglob("__init__.py"):
        text = init.read_text().lstrip()
        assert text.startswith('"""'), init
