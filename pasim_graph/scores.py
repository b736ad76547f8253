"""Scores of a run: bias and standard deviation of every error field a scorer wrote, for each
sweep of a store and pooled over the whole volume, with the volume's time on target (the sum
of the dwells: what a phased array's update time is made of)."""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np
import xarray as xr

from .fm301 import BEAM_DIMENSIONS, sweep_names

#: The store attribute (root and each sweep) holding the time on target, in seconds.
TIME_ON_TARGET = "pasim_time_on_target_s"

PRT = TypeVar("PRT", float, np.ndarray)


def mean_prt(t1_s: PRT, ratio: PRT) -> PRT:
    """The mean pulse spacing of a staggered dwell, T1 (1 + 1 / ratio) / 2: its pulses
    alternate T1 and T2 = T1 / ratio apart (``ratio`` = T1 / T2, a scan's ``prt_ratio``).

    The one definition the scans (their dwell times) and the scores (the time on target)
    share: both must agree to the bit on how long a staggered sweep takes.
    """
    return t1_s * (1.0 + 1.0 / ratio) / 2.0


def time_on_target(sweep: xr.Dataset) -> float:
    """Sum over the beams of pulses x PRT, in seconds (0 when the sweep says neither).

    A staggered scan's PRT is its mean (:func:`mean_prt` of ``prt``, T1, and ``prt_ratio``).
    ``pulses`` is one number per sweep or one per beam.
    """
    if "prt" not in sweep.variables or "pulses" not in sweep.variables:
        return 0.0
    prt = np.asarray(sweep["prt"].values, dtype=np.float64)
    if "prt_ratio" in sweep.variables:
        prt = mean_prt(prt, np.asarray(sweep["prt_ratio"].values, dtype=np.float64))
    pulses = np.broadcast_to(np.asarray(sweep["pulses"].values, dtype=np.float64), prt.shape)
    return float(np.sum(pulses * prt))


def summarize(*sweeps: xr.Dataset) -> dict[str, dict[str, Any]]:
    """Bias and standard deviation of every error field a scorer wrote, pooled over the gates
    of the ``sweeps`` given (one sweep, or every sweep of a volume).

    Error fields carry ``pasim_role = "error"`` and the requirement they are judged against;
    a field with ``pasim_role = "scored"`` marks the gates that met the scoring rule, so that
    scored gates without an estimate (undefined, e.g. noise-corrected power <= 0) are counted.
    """
    n_scored: int | None = None
    excluded_n, any_excluded = 0, False
    reasons: list[str] = []
    pooled: dict[str, dict[str, Any]] = {}
    for sweep in sweeps:
        scored = [v for v in sweep.data_vars.values() if v.attrs.get("pasim_role") == "scored"]
        if scored:
            n_scored = (n_scored or 0) + int(np.asarray(scored[0].values).sum())
        # Gates a scorer set apart (e.g. overlaid by another trip): counted, not scored.
        excluded = [v for v in sweep.data_vars.values() if v.attrs.get("pasim_role") == "excluded"]
        if excluded:
            any_excluded = True
            excluded_n += sum(int(np.asarray(v.values).sum()) for v in excluded)
            reason = "; ".join(str(v.attrs.get("excluded", "")) for v in excluded)
            if reason not in reasons:
                reasons.append(reason)
        for name, var in sweep.data_vars.items():
            if var.attrs.get("pasim_role") != "error":
                continue
            values = np.asarray(var.values, dtype=np.float64)
            finite = np.isfinite(values)
            # Scored gates whose truth has this moment but whose estimate is undefined.
            unestimated = 0
            truth_name = var.attrs.get("truth_variable")
            if scored and truth_name in sweep:
                has_truth = np.isfinite(np.asarray(sweep[truth_name].values))
                unestimated = int(
                    (np.asarray(scored[0].values).astype(bool) & has_truth & ~finite).sum()
                )
            key = str(var.attrs.get("moment", name))
            entry = pooled.setdefault(key, {"values": [], "unestimated": 0, "attrs": var.attrs})
            entry["values"].append(values[finite].ravel())
            entry["unestimated"] += unestimated
    extra = {"excluded": excluded_n, "excluded_reason": "; ".join(reasons)}
    out: dict[str, dict[str, Any]] = {}
    for key, entry in pooled.items():
        values = np.concatenate(entry["values"])
        n = int(values.size)
        attrs = entry["attrs"]
        bias = float(values.mean()) if n else float("nan")
        std = float(values.std(ddof=1)) if n > 1 else float("nan")
        req_b = float(attrs["requirement_bias"])
        req_s = float(attrs["requirement_std"])
        out[key] = {
            "bias": bias,
            "std": std,
            "count": n,
            "units": attrs.get("units", ""),
            "requirement_bias": req_b,
            "requirement_std": req_s,
            "pass": bool(n > 1 and abs(bias) <= req_b and std <= req_s),
            "scored_gates": n_scored if n_scored is not None else n,
            "unestimated": entry["unestimated"],
            "scored": attrs.get("scored", ""),
            **(extra if any_excluded else {}),
        }
    return out


def no_truth(*sweeps: xr.Dataset) -> list[str]:
    """The moments the ``sweeps`` estimate but their truth does not hold (the scorer names
    them in its ``scored`` field's ``no_truth``): not scored, never to be read as scored."""
    out: list[str] = []
    for sweep in sweeps:
        for var in sweep.data_vars.values():
            if var.attrs.get("pasim_role") == "scored":
                out += [n for n in str(var.attrs.get("no_truth", "")).split() if n not in out]
    return out


def volume_scores(tree: xr.DataTree) -> dict[str, Any]:
    """Each sweep's scores and time on target, and the volume's (scores pooled over every
    sweep's gates, time on target summed), as JSON-ready data."""
    sweeps = {name: tree[name].to_dataset() for name in sweep_names(tree)}
    out: dict[str, Any] = {"sweeps": {}}
    for name, ds in sweeps.items():
        out["sweeps"][name] = {
            "fixed_angle_deg": _fixed_angle(ds),  # elevation of a PPI, azimuth of an RHI
            "sweep_mode": str(ds["sweep_mode"].values) if "sweep_mode" in ds else "",
            "beams": int(ds.sizes.get(_beam_dim(ds), 0)),
            "time_on_target_s": time_on_target(ds),
            "scores": summarize(ds),
            "no_truth": no_truth(ds),
        }
    out["time_on_target_s"] = sum(s["time_on_target_s"] for s in out["sweeps"].values())
    out["scores"] = summarize(*sweeps.values())
    out["no_truth"] = no_truth(*sweeps.values())
    return out


def _fixed_angle(ds: xr.Dataset) -> float | None:
    if "sweep_fixed_angle" not in ds:
        return None
    return float(ds["sweep_fixed_angle"].values)


def _beam_dim(ds: xr.Dataset) -> str:
    return next((d for d in BEAM_DIMENSIONS if d in ds.dims), "")


def print_scores(
    scores: dict[str, dict[str, Any]], stream: Any, no_truth: list[str] | None = None
) -> None:
    """The score table of one sweep or a volume, with what was not scored and why: a moment
    of ``no_truth`` has a row that says so."""
    if not scores:
        return
    # Products of sweep-level blocks have longer names than the moments (VRADH_DEALIASED_...).
    w = max(8, *(len(n) for n in scores))
    print(
        f"{'moment':{w}} {'bias':>9} {'std':>9} {'count':>8}  {'req bias/std':>14}  pass",
        file=stream,
    )
    for name, s in scores.items():
        req = f"{s['requirement_bias']:g}/{s['requirement_std']:g}"
        print(
            f"{name:{w}} {s['bias']:9.4f} {s['std']:9.4f} {s['count']:8d}  {req:>14}  "
            f"{'yes' if s['pass'] else 'no'}",
            file=stream,
        )
    for name in no_truth or []:
        if name not in scores:
            print(
                f"{name:{w}} {'no truth':>9}  (the truth holds no {name}: not scored)", file=stream
            )
    first = next(iter(scores.values()))
    if first.get("scored"):
        print(f"scored gates: {first['scored']}", file=stream)
    if first.get("excluded"):
        print(
            f"not scored: {first['excluded']} gates that meet the rule, {first['excluded_reason']}",
            file=stream,
        )
    n = first.get("scored_gates", first["count"])
    if n == 0:
        print(
            "no gate met the scoring rule: nothing to score (is the sector all masked?)",
            file=stream,
        )
        return
    for name, s in scores.items():
        if s.get("unestimated"):
            print(
                f"{name}: {s['unestimated']} of {n} scored gates have no estimate (censored "
                "below the processor's SNR threshold, or undefined: noise-corrected power <= 0)",
                file=stream,
            )


def print_volume(volume: dict[str, Any], stream: Any) -> None:
    """A store's score tables: one sweep's as before; a volume's per sweep, then pooled. The
    time on target follows each."""
    sweeps = volume["sweeps"]
    if len(sweeps) <= 1:
        print_scores(volume["scores"], stream, volume.get("no_truth"))
        if volume["time_on_target_s"]:
            print(f"time on target: {volume['time_on_target_s']:.3f} s", file=stream)
        return
    for name, s in sweeps.items():
        angle = s["fixed_angle_deg"]
        at = f" at {angle:g} deg" if angle is not None else ""
        print(
            f"{name} ({s['sweep_mode'] or 'sweep'}{at}, {s['beams']} beams, time on target "
            f"{s['time_on_target_s']:.3f} s)",
            file=stream,
        )
        print_scores(s["scores"], stream, s.get("no_truth"))
        print(file=stream)
    print(
        f"volume ({len(sweeps)} sweeps, time on target {volume['time_on_target_s']:.3f} s)",
        file=stream,
    )
    print_scores(volume["scores"], stream, volume.get("no_truth"))
