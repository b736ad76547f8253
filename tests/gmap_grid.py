"""The GMAP grid: the simulator's spectral processor with GMAP against the independent GMAP
of ``tests.reference.gmap`` on the same I/Q, and both against the truth.

The I/Q comes from the chain of ``graphs/uniform_clutter.yaml`` (uniform 30 dBZ scene at
5 m/s, width 2 m/s; uniform clutter map; fixed SNR at every gate from ``receiver.snr_db``):
the receiver's output, which the processor turns into the moments the run stores. The
independent GMAP reads the same I/Q and the receiver's noise power and turns its power into
reflectivity with the weather channel's radar constant, as any processor does. Used by
``tests/processing/test_doppler_gmap_grid.py`` and ``benchmarks/gmap_grid.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import load
from tests.reference.gmap import gmap_moments

GRAPH = Path(__file__).resolve().parents[1] / "graphs" / "uniform_clutter.yaml"
TRUTH_DBZ = 30.0
TRUTH_VELOCITY_MS = 5.0
SNRS_DB = (0.0, 10.0, 20.0, 30.0)
CSRS_DB = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0)


def chain(overrides: dict[str, Any], seed: int) -> dict[tuple[str, str], Any]:
    """Every block output of one run of the graph (all its beams in one chunk): the
    executor's own per-block step, so the receiver's I/Q and noise power are those the
    processor read."""
    ex = LocalExecutor(load(GRAPH, overrides), RunOptions(seed=seed, chunk_beams=10**6))
    ex.load()
    values = ex.run_static()
    beams = np.arange(ex.plan.beam_count)
    for name in ex.plan.per_chunk:
        ex._run_block(name, values, beams)
    return values


def wrap(dv: np.ndarray, nyquist: float) -> np.ndarray:
    return np.mod(dv + nyquist, 2 * nyquist) - nyquist


def grid_point(
    snr_db: float | None, clutter_dbz: float, seed: int, beams: int = 4, **extra: Any
) -> dict[str, Any]:
    """One run: per-gate DBZH and VRADH errors against the truth, project and independent.

    ``clutter_dbz``: the clutter map (the weather is 30 dBZ, so CSR = clutter_dbz - 30).
    """
    overrides = {
        "clutter.clutter_dbz": clutter_dbz,
        "scan.azimuth_stop_deg": float(beams),
        **({"receiver.snr_db": snr_db} if snr_db is not None else {}),
        **extra,
    }
    v = chain(overrides, seed)
    iq = v[("receiver", "iq")]
    noise = np.asarray(v[("receiver", "noise_power")])[..., 0]
    cal = v[("weather", "calibration")]
    moments = v[("spectral", "moments")]
    prt = float(v[("scan", "beams")]["prt"].values[0])
    lam = float(cal.attrs["wavelength_m"])
    width_c = float(load(GRAPH, overrides).params["spectral"].get("clutter_width_ms", 0.25))
    n_b, n_g = iq.shape[:2]
    ref = gmap_moments(
        np.asarray(iq)[..., 0].reshape(n_b * n_g, -1), noise.ravel(), prt, lam, width_c
    )
    const = np.asarray(cal["radar_constant_db"].values)[:, :1]
    rng = np.asarray(cal["range"].values)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = ref["power"].reshape(n_b, n_g)
        dbz_ref = 10 * np.log10(np.where(p > 0, p, np.nan)) + 20 * np.log10(rng) - const
    nyquist = lam / (4 * prt)
    return {
        "dbz_project": np.asarray(moments["DBZH"].values, np.float64) - TRUTH_DBZ,
        "dbz_independent": dbz_ref - TRUTH_DBZ,
        "vel_project": wrap(
            np.asarray(moments["VRADH"].values, np.float64) - TRUTH_VELOCITY_MS, nyquist
        ),
        "vel_independent": wrap(ref["velocity"].reshape(n_b, n_g) - TRUTH_VELOCITY_MS, nyquist),
        "windows": ref["window"],
        "nyquist": nyquist,
    }


def summary(point: dict[str, Any]) -> dict[str, float]:
    """Mean DBZH and VRADH errors (dB, m/s) of the project and the independent GMAP, on the
    gates where both gave an estimate, and the share of such gates."""
    z_p, z_i = point["dbz_project"], point["dbz_independent"]
    v_p, v_i = point["vel_project"], point["vel_independent"]
    ok = np.isfinite(z_p) & np.isfinite(z_i) & np.isfinite(v_p) & np.isfinite(v_i)
    return {
        "dbz_project": float(np.mean(z_p[ok])),
        "dbz_independent": float(np.mean(z_i[ok])),
        "vel_project": float(np.mean(v_p[ok])),
        "vel_independent": float(np.mean(v_i[ok])),
        "gates": float(ok.mean()),
        "both_nan": float((np.isnan(z_p) == np.isnan(z_i)).mean()),
    }
