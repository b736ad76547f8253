"""The radar at a glance: a system summary derived from a graph, and each block's key values.

The engine knows no physics and never imports the block library, so the summary is read
from the graph's parameters by name, the names the library's blocks declare (with their
units in the suffix): the scan-role block's ``prt_s``, an antenna's ``beamwidth_deg`` and
``gain_db``, a waveform's ``width_s`` (and ``bandwidth_hz`` if it sweeps one), and
``frequency_hz``, ``peak_power_w``, ``loss_db``, ``noise_figure_db``, ``transmission``
wherever a block declares them. Values are the ones the graph runs with: the file's
(through its variables) or the type's default. A quantity whose inputs the graph lacks is
left out, with the reason.

Formulas (Doviak and Zrnic, *Doppler Radar and Weather Observations*, 2nd ed.):

- PRF = 1 / PRT; unambiguous range r_a = c PRT / 2 (eq. 3.5); Nyquist velocity
  v_a = lambda / (4 PRT) (eq. 3.14), lambda = c / f.
- Range resolution c tau / 2 for an unmodulated pulse, c / (2 B) for a swept bandwidth B.
- Sensitivity: the reflectivity whose echo at range r equals the noise (SNR 0 dB),
  with the weather radar equation for a Gaussian beam (Probert-Jones; eq. 4.34)
  ``P_r = pi^3 P_t G^2 theta^2 c tau |K_w|^2 Z / (1024 ln2 lambda^2 r^2 L)`` and the noise
  ``N = k T0 F B_n`` after a matched filter (B_n = 1/tau, or B for a swept pulse, whose
  compression gain tau B restores the energy of the whole pulse), |K_w|^2 = 0.93,
  T0 = 290 K.
"""

from __future__ import annotations

import math
from typing import Any

from .. import registry
from ..graphfile import GraphSpec

C = 299_792_458.0  # m/s
BOLTZMANN = 1.380_649e-23  # J/K
T0_K = 290.0
KW2 = 0.93
SENSITIVITY_RANGE_M = 50e3

_PREFIXES = [(1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "u"), (1e-9, "n")]
#: Units the summary scales with an SI prefix (2.8 GHz, 1.6 us, 700 kW).
_SCALED = {"Hz", "s", "W", "m"}
_MODES = {"shv": "SHV: H and V on every pulse", "ahv": "AHV: H and V alternate, H first"}


def quantity(value: float, units: str, digits: int = 3) -> str:
    """``value`` with its units, scaled by an SI prefix for Hz, s, W and m (2.8 GHz)."""
    if not math.isfinite(value):
        return f"{value} {units}".strip()
    if units in _SCALED and value != 0:
        for scale, prefix in _PREFIXES:
            if abs(value) >= scale * 0.9995:
                return f"{value / scale:.{digits}g} {prefix}{units}"
        scale, prefix = _PREFIXES[-1]
        return f"{value / scale:.{digits}g} {prefix}{units}"
    text = f"{value:.{digits}g}"
    return f"{text} {units}" if units else text


class Values:
    """The values a graph's blocks run with, found by parameter name."""

    def __init__(self, spec: GraphSpec):
        self.spec = spec
        self.classes = {
            n: c for n, b in spec.blocks.items() if (c := registry.get(b.type)) is not None
        }

    def value(self, block: str, param: str) -> Any:
        cls = self.classes[block]
        raw = self.spec.blocks[block].params.get(param, cls.params[param].default)
        if isinstance(raw, str) and raw.startswith("$"):
            raw = self.spec.variables.get(raw[1:])
        return raw

    def find(self, param: str, prefer: str = "", role: str = "") -> tuple[str, Any] | None:
        """(block, value) of ``param``: from a block of ``role``, else one whose type starts
        with ``prefer``, else the first block (by name) that declares it."""
        having = sorted(n for n, c in self.classes.items() if param in c.params)
        ranked = sorted(
            having,
            key=lambda n: (
                not (role and self.classes[n].role == role),
                not (prefer and self.spec.blocks[n].type.startswith(prefer)),
                n,
            ),
        )
        return (ranked[0], self.value(ranked[0], param)) if ranked else None

    def number(self, param: str, prefer: str = "", role: str = "") -> tuple[str, float] | None:
        found = self.find(param, prefer, role)
        if found is None:
            return None
        block, v = found
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return None
        return block, float(v)


def system_summary(spec: GraphSpec) -> dict[str, Any]:
    """The radar's key quantities derived from its graph.

    Returns ``{"rows": [{"key", "label", "value", "units", "text", "from"}], "missing":
    [why]}``; ``value`` is in SI units (``units``), ``text`` the value as shown, ``from``
    the parameters it was derived from (``block.param``).
    """
    v = Values(spec)
    rows: list[dict[str, Any]] = []
    missing: list[str] = []

    def add(key: str, label: str, value: float, units: str, sources: list[str], text=None):
        rows.append(
            {
                "key": key,
                "label": label,
                "value": value,
                "units": units,
                "text": text or quantity(value, units),
                "from": sources,
            }
        )

    mode = v.find("transmission")
    if mode is not None and isinstance(mode[1], str):
        rows.append(
            {
                "key": "transmit_mode",
                "label": "Transmit mode",
                "value": mode[1],
                "units": "",
                "text": _MODES.get(mode[1], mode[1]),
                "from": [f"{mode[0]}.transmission"],
            }
        )
    freq = v.number("frequency_hz")
    prt = v.number("prt_s", role="scan")
    if freq:
        add("frequency", "Frequency", freq[1], "Hz", [f"{freq[0]}.frequency_hz"])
        lam = C / freq[1]
        add(
            "wavelength", "Wavelength", lam, "m", [f"{freq[0]}.frequency_hz"], f"{lam * 100:.3g} cm"
        )
    else:
        missing.append("no block declares frequency_hz: no wavelength, Nyquist or sensitivity")
    if prt:
        src = [f"{prt[0]}.prt_s"]
        add("prf", "PRF", 1.0 / prt[1], "Hz", src)
        add("unambiguous_range", "Unambiguous range", C * prt[1] / 2, "m", src)
        if freq:
            nyquist = C / freq[1] / (4 * prt[1])
            add(
                "nyquist_velocity",
                "Nyquist velocity",
                nyquist,
                "m/s",
                [*src, f"{freq[0]}.frequency_hz"],
                f"{nyquist:.1f} m/s",
            )
    else:
        missing.append("no block declares prt_s: no PRF, unambiguous range or Nyquist velocity")
    beam = v.number("beamwidth_deg", prefer="antenna")
    if beam:
        add("beamwidth", "Beamwidth", beam[1], "deg", [f"{beam[0]}.beamwidth_deg"])
    else:
        missing.append("no antenna declares beamwidth_deg (an array's beam follows its layout)")
    width = v.number("width_s", prefer="waveform")
    band = v.number("bandwidth_hz", prefer="waveform")
    if band:
        add(
            "range_resolution",
            "Range resolution",
            C / (2 * band[1]),
            "m",
            [f"{band[0]}.bandwidth_hz"],
        )
    elif width:
        add("range_resolution", "Range resolution", C * width[1] / 2, "m", [f"{width[0]}.width_s"])
    else:
        missing.append("no waveform declares width_s or bandwidth_hz: no range resolution")
    if width:
        add("pulse_width", "Pulse width", width[1], "s", [f"{width[0]}.width_s"])
    power = v.number("peak_power_w")
    gain = v.number("gain_db", prefer="antenna")
    nf = v.number("noise_figure_db", prefer="receiver")
    loss = v.number("loss_db") or ("", 0.0)
    needs = {
        "frequency_hz": freq,
        "peak_power_w": power,
        "gain_db": gain,
        "beamwidth_deg": beam,
        "width_s": width,
        "noise_figure_db": nf,
    }
    if all(needs.values()):
        z = sensitivity_dbz(
            SENSITIVITY_RANGE_M,
            power[1],  # type: ignore[index]
            gain[1],  # type: ignore[index]
            beam[1],  # type: ignore[index]
            width[1],  # type: ignore[index]
            freq[1],  # type: ignore[index]
            nf[1],  # type: ignore[index]
            loss[1],
            band[1] if band else None,
        )
        sources = [f"{b[0]}.{k}" for k, b in needs.items() if b]
        if band:
            sources.append(f"{band[0]}.bandwidth_hz")
        if loss[0]:
            sources.append(f"{loss[0]}.loss_db")
        add("sensitivity_50km", "Sensitivity at 50 km", z, "dBZ", sources, f"{z:.1f} dBZ")
    else:
        lacking = ", ".join(k for k, b in needs.items() if not b)
        missing.append(f"sensitivity needs {lacking}")
    return {"rows": rows, "missing": missing}


def sensitivity_dbz(
    range_m: float,
    peak_power_w: float,
    gain_db: float,
    beamwidth_deg: float,
    width_s: float,
    frequency_hz: float,
    noise_figure_db: float,
    loss_db: float = 0.0,
    bandwidth_hz: float | None = None,
) -> float:
    """Reflectivity (dBZ) whose echo at ``range_m`` equals the receiver noise (module doc)."""
    lam = C / frequency_hz
    g = 10 ** (gain_db / 10)
    theta = math.radians(beamwidth_deg)
    noise_bw = bandwidth_hz if bandwidth_hz else 1.0 / width_s
    noise = BOLTZMANN * T0_K * 10 ** (noise_figure_db / 10) * noise_bw
    constant = (math.pi**3 * peak_power_w * g**2 * theta**2 * C * width_s * KW2) / (
        1024 * math.log(2) * lam**2 * 10 ** (loss_db / 10)
    )
    z = noise * range_m**2 / constant  # m^6 m^-3
    return 10 * math.log10(z / 1e-18)  # 1 mm^6 m^-3 = 1e-18 m^6 m^-3


def key_values(spec: GraphSpec) -> dict[str, list[dict[str, str]]]:
    """Each block's key values for the canvas: the parameters the file sets (through its
    variables too), as ``{"name", "text"}`` with units (2.8 GHz, 700 kW, 1.6 us); those in
    Hz, s, W or m first (what a radar engineer names a system by), then the others."""
    v = Values(spec)
    out: dict[str, list[dict[str, str]]] = {}
    for name, b in spec.blocks.items():
        cls = v.classes.get(name)
        if cls is None:
            continue
        shown = []
        for key in b.params:
            decl = cls.params.get(key)
            if decl is None:
                continue
            value = v.value(name, key)
            if isinstance(value, bool):
                text = "yes" if value else "no"
            elif isinstance(value, (int, float)) and math.isfinite(value):
                text = quantity(float(value), decl.units or "")
            elif isinstance(value, str) and len(value) <= 40:
                text = value
            else:
                continue
            shown.append((decl.units not in _SCALED, {"name": key, "text": text}))
        out[name] = [item for _, item in sorted(shown, key=lambda x: x[0])]
    return out
