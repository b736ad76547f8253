from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GRAPHS = ROOT / "graphs"
FIXTURES = Path(__file__).parent / "fixtures"


def run_cli(
    *args: str, env: dict[str, str] | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``pasim`` in a fresh interpreter, as a user would."""
    full_env = {**os.environ, **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "pasim_graph", *args],
        capture_output=True,
        text=True,
        env=full_env,
        cwd=cwd or ROOT,
        timeout=600,
    )


@pytest.fixture(scope="session")
def truth_dataset():
    """The bundled scene as the truth block hands it on."""
    import numpy as np
    from pasim_blocks.truth.nexrad import NexradTruth

    from pasim_graph import Chunk

    block = NexradTruth(name="truth")
    return block.process({}, Chunk(beams=np.arange(0), resource=block.load()))["truth"]
