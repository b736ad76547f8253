"""The block library's layout: old flat import paths still resolve (with a warning naming the
new one), no module is over about 600 lines, and the wheel's package list is found, not typed."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from pasim_blocks.deprecated import MOVED, PACKAGES

ROOT = Path(__file__).resolve().parents[1]

# One name each old module was imported for, to check it resolves to the new home.
SAMPLE = {
    "pasim_blocks.waveform": "LinearFM",
    "pasim_blocks.nlfm": "optimised_envelope",
    "pasim_blocks.compression": "sidelobes",
    "pasim_blocks.amplifier": "SalehAmplifier",
    "pasim_blocks.jitter": "TransmitterJitter",
    "pasim_blocks.antenna": "PlanarPatchArray",
    "pasim_blocks.cylindrical": "CylindricalArray",
    "pasim_blocks.elements": "make_element",
    "pasim_blocks.electronics": "ChannelModel",
    "pasim_blocks.measured_pattern": "write_pattern_file",
    "pasim_blocks.patterns": "planar_array_directivity_db",
    "pasim_blocks.truth": "NexradTruth",
    "pasim_blocks.scene": "UniformScene",
    "pasim_blocks.nexrad_io": "read_truth_sweep",
    "pasim_blocks.scan": "PPISector",
    "pasim_blocks.weather": "WeatherChannel",
    "pasim_blocks.fasttime": "range_model",
    "pasim_blocks.polarimetry": "cholesky",
    "pasim_blocks.receiver": "Receiver",
    "pasim_blocks.matched_filter": "MatchedFilter",
    "pasim_blocks.ppp": "PulsePairProcessor",
    "pasim_blocks.scorer": "NexradScorer",
    "pasim_blocks.waveform_command": "COMMAND",
    "pasim_blocks.pattern_command": "COMMAND",
}


def test_every_old_module_has_a_sample() -> None:
    assert set(SAMPLE) == set(MOVED)


@pytest.mark.parametrize("old", sorted(SAMPLE))
def test_old_flat_path_still_resolves_with_a_warning(old: str) -> None:
    # A fresh interpreter: the warning is given once per import, and other tests import these.
    name = SAMPLE[old]
    code = (
        "import warnings, importlib\n"
        "warnings.simplefilter('error')\n"
        f"module = importlib.import_module({old!r})\n"
        "try:\n"
        f"    value = getattr(module, {name!r})\n"
        "except DeprecationWarning as w:\n"
        "    print('WARN', w)\n"
        "    warnings.simplefilter('ignore')\n"
        f"    value = getattr(module, {name!r})\n"
        "print('MODULE', value.__module__ if hasattr(value, '__module__') else '')\n"
    )
    if old not in PACKAGES:
        # The import itself warns.
        code = code.replace("warnings.simplefilter('error')\n", "", 1)
        code = "import warnings\nwarnings.simplefilter('always')\n" + code
    out = subprocess.run(
        [sys.executable, "-W", "always", "-c", code], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    text = out.stdout + out.stderr
    assert "DeprecationWarning" in text or "WARN" in text, text
    new_homes = MOVED[old]
    assert any(new in text for new in new_homes), text
    # The name resolves to the very object the new module holds.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        value = getattr(importlib.import_module(old), name)
    assert any(getattr(importlib.import_module(new), name, None) is value for new in new_homes)


def test_old_package_paths_warn_on_lookup() -> None:
    import pasim_blocks.weather as weather

    with pytest.warns(DeprecationWarning, match=r"pasim_blocks\.weather\.channel"):
        cls = weather.WeatherChannel
    from pasim_blocks.weather.channel import WeatherChannel

    assert cls is WeatherChannel
    with pytest.raises(AttributeError):
        weather.no_such_name  # noqa: B018


def test_new_paths_import_without_warnings() -> None:
    code = (
        "import warnings\nwarnings.simplefilter('error')\n"
        "import pasim_blocks.weather.channel, pasim_blocks.truth.nexrad\n"
        "import pasim_blocks.antennas.planar\n"
        "from pasim_blocks.weather import cells\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def test_no_block_library_module_is_over_about_600_lines() -> None:
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "blocks").rglob("*.py")
        if (n := len(p.read_text().splitlines())) > 620
    }
    assert not long, long


def test_every_subpackage_has_a_docstring() -> None:
    for init in (ROOT / "blocks").rglob("__init__.py"):
        text = init.read_text().lstrip()
        assert text.startswith('"""'), init
