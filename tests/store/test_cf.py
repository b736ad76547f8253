"""The CF/Radial attribute snapshot (``pasim_graph/data/cf_attributes.json``) is xradar's
data model as the installed xradar gives it: same dictionaries, same order."""

from __future__ import annotations

import dataclasses
import json

from pasim_graph import fm301 as cf


def test_the_snapshot_is_the_installed_xradars_model() -> None:
    saved = json.loads(cf.SNAPSHOT.read_text())
    live = dataclasses.asdict(cf.from_xradar())
    assert saved["attributes"] == live, "stale snapshot: run python -m pasim_graph.fm301"
    for key in live:  # the order of names too, which the store's attributes keep
        assert list(saved["attributes"][key]) == list(live[key])


def test_attributes_come_from_the_snapshot_without_importing_xradar() -> None:
    import subprocess
    import sys

    code = (
        "import sys; from pasim_graph.fm301 import cf_attributes; a = cf_attributes(); "
        "print(a.var('DBZH')['units'], 'xradar' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == [cf.from_xradar().var("DBZH")["units"], "False"]


def test_another_xradar_version_reads_xradar_itself(tmp_path, monkeypatch) -> None:
    saved = json.loads(cf.SNAPSHOT.read_text())
    saved["xradar"] = "0.0.1"
    saved["attributes"]["range"] = {"units": "furlongs"}
    stale = tmp_path / "cf.json"
    stale.write_text(json.dumps(saved))
    monkeypatch.setattr(cf, "SNAPSHOT", stale)
    cf.cf_attributes.cache_clear()
    try:
        assert cf.cf_attributes().range == cf.from_xradar().range
    finally:
        cf.cf_attributes.cache_clear()
