"""The report's hardware section: for each system, the antenna pattern of the beam at the
sector's centre, the range response of its waveform and filter, and its radiated spectrum
against the RSEC mask, drawn from what :mod:`.hardware` measured; and one table of their
figures, systems as columns."""

from __future__ import annotations

from typing import Any

import numpy as np

from .figures import Figure, canvas, uri
from .hardware import is_number

#: Rows of the hardware table: (part, key, label, scale, format).
TABLE_ROWS = (
    ("pattern", "beamwidth_az_deg", "beamwidth, azimuth (deg)", 1.0, "{:.2f}"),
    ("pattern", "beamwidth_el_deg", "beamwidth, elevation (deg)", 1.0, "{:.2f}"),
    ("pattern", "peak_sidelobe_db", "peak sidelobe (dB)", 1.0, "{:.1f}"),
    ("pattern", "peak_gain_dbi", "peak gain (dBi)", 1.0, "{:.1f}"),
    ("pattern", "cross_pol_db", "cross-polar level in the main beam (dB)", 1.0, "{:.1f}"),
    ("pattern", "zdr_bias_db", "two-way H/V ratio at the peak (dB)", 1.0, "{:.3f}"),
    ("waveform", "pulse_width_s", "pulse width (us)", 1e6, "{:.3g}"),
    ("waveform", "range_resolution_m", "range resolution (m)", 1.0, "{:.0f}"),
    ("waveform", "psl_db", "range sidelobe, peak (dB)", 1.0, "{:.1f}"),
    ("waveform", "isl_db", "range sidelobe, integrated (dB)", 1.0, "{:.1f}"),
    ("waveform", "blind_range_m", "blind range (m)", 1.0, "{:.0f}"),
    ("waveform", "snr_loss_db", "mismatch loss (dB)", 1.0, "{:.2f}"),
    ("spectrum", "bandwidth_40_hz", "-40 dB bandwidth (MHz)", 1e-6, "{:.2f}"),
    ("spectrum", "bandwidth_40_allowed_hz", "RSEC allowed -40 dB bandwidth (MHz)", 1e-6, "{:.2f}"),
    ("spectrum", "margin_db", "margin to the RSEC mask (dB)", 1.0, "{:.1f}"),
)


def hardware_table(hardware: dict[str, Any], systems: list[str]) -> list[dict[str, Any]]:
    """One row per figure: its label and each system's value as text ("n/a": not measured)."""
    rows = []
    for part, key, label, scale, fmt in TABLE_ROWS:
        cells = []
        for s in systems:
            v = ((hardware.get(s) or {}).get(part) or {}).get("figures", {}).get(key)
            cells.append(fmt.format(v * scale) if is_number(v) else "n/a")
        if any(c != "n/a" for c in cells):
            rows.append({"label": label, "cells": cells})
    verdicts = []
    for s in systems:
        f = ((hardware.get(s) or {}).get("spectrum") or {}).get("figures", {})
        verdicts.append(
            ("passes" if f["passes"] else "fails") + f" (category {f['category']})"
            if "passes" in f
            else "n/a"
        )
    if any(v != "n/a" for v in verdicts):
        rows.append({"label": "RSEC emission mask", "cells": verdicts})
    return rows


def hardware_figure(system: str, hw: dict[str, Any]) -> Figure:
    """Pattern cut, range response and spectrum of one system, side by side."""
    fig = canvas(13.0, 3.6)
    ax = fig.subplots(1, 3)
    said = []
    pat, wav, spec = hw.get("pattern", {}), hw.get("waveform", {}), hw.get("spectrum", {})
    a = ax[0]
    if "cut_deg" in pat:
        f = pat["figures"]
        a.plot(pat["cut_deg"], pat["h_db"], color="C0", lw=0.8, label="H port")
        a.plot(pat["cut_deg"], pat["v_db"], color="C1", lw=0.8, ls="--", label="V port")
        a.axhline(f["peak_sidelobe_db"], color="C3", lw=0.8, ls=":", label="peak sidelobe")
        a.set_title(
            f"(a) azimuth cut at {f['beam_azimuth_deg']:.1f} deg, "
            f"{f['beamwidth_az_deg']:.2f} deg wide",
            fontsize=9,
        )
        a.set(xlabel="azimuth from the beam (deg)", ylabel="one-way power (dB of peak)")
        a.set_ylim(-80, 3)
        a.legend(fontsize=7, loc="upper right")
    else:
        said.append(f"pattern: {pat.get('missing', 'not measured')}")
        a.axis("off")
    a = ax[1]
    if "actual_db" in wav:
        f = wav["figures"]
        a.plot(
            np.array(wav["ideal_offset_m"]) / 1e3,
            wav["ideal_db"],
            color="0.5",
            lw=0.8,
            label="ideal amplifier",
        )
        a.plot(
            np.array(wav["actual_offset_m"]) / 1e3,
            wav["actual_db"],
            color="C0",
            lw=0.8,
            ls="--",
            label="through the graph's amplifier",
        )
        psl = f"PSL {f['psl_db']:.1f} dB" if is_number(f["psl_db"]) else "no range sidelobes"
        a.set_title(
            f"(b) range response: {psl}, {f['range_resolution_m']:.0f} m resolution", fontsize=9
        )
        a.set(xlabel="range offset (km)", ylabel="filter output (dB of peak)")
        a.set_ylim(-100, 3)
        a.legend(fontsize=7, loc="upper right")
    else:
        said.append(f"waveform: {wav.get('missing', 'not measured')}")
        a.axis("off")
    a = ax[2]
    if "freq_hz" in spec:
        f = spec["figures"]
        mhz = np.array(spec["freq_hz"]) / 1e6
        a.plot(mhz, spec["radiated_db"], color="C0", lw=0.8, label="radiated")
        a.plot(mhz, spec["mask_db"], color="C3", lw=1.2, label=f"RSEC {f['category']} mask")
        verdict = "passes" if f["passes"] else "fails"
        a.set_title(f"(c) spectrum: {verdict} the mask, margin {f['margin_db']:.1f} dB", fontsize=9)
        a.set(xlabel="offset from the carrier (MHz)", ylabel="PSD (dB below peak)")
        a.set_ylim(-spec["spurious_db"] - 30, 3)
        a.legend(fontsize=7, loc="upper right")
    else:
        said.append(f"spectrum: {spec.get('missing', 'not measured')}")
        a.axis("off")
    for a in ax:
        a.grid(alpha=0.3)
    point = "" if hw.get("point", "-") == "-" else f" at {hw['point']}"
    fig.suptitle(f"{system}{point}", fontsize=10)
    caption = (
        "The beam steered to the sector's centre (the run seed's channel errors), the range "
        "response of the graph's waveform, amplifier and filter (as pasim waveform), and the "
        "radiated spectrum against the NTIA RSEC mask (as pasim spectrum)."
    )
    if said:
        caption += " Not drawn: " + "; ".join(said) + "."
    return Figure(
        f"{system}: antenna, waveform and spectrum",
        uri(fig),
        f"Antenna pattern cut, range response and transmitted spectrum of {system}",
        caption,
    )
