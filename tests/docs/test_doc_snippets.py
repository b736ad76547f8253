"""Python examples of the docs run as a user runs them: saved as a script and started with
``python script.py`` (the scaling guide's example re-ran itself in every spawned worker
without its ``if __name__ == "__main__":`` guard)."""

from __future__ import annotations

import re
import subprocess
import sys

import xarray as xr

from ..conftest import ROOT


def snippet(doc: str, after: str) -> str:
    """The first ```python block of ``doc`` after the heading ``after``."""
    text = (ROOT / doc).read_text()
    rest = text[text.index(after) :]
    return re.search(r"```python\n(.*?)```", rest, re.S).group(1)


def test_the_scaling_guides_python_example_runs_as_a_script(tmp_path):
    code = snippet("docs/scaling.md", "## From Python")
    assert 'if __name__ == "__main__":' in code
    script = tmp_path / "example.py"
    script.write_text(code)
    (tmp_path / "graphs").symlink_to(ROOT / "graphs")
    res = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stderr[-3000:]
    sweep = xr.open_datatree(tmp_path / "g.zarr", engine="zarr")["sweep_0"]
    assert sweep.sizes["azimuth"] == 10  # 240-250 deg at 1 deg: the example's own sector
