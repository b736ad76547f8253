"""The names a radar file gives its fields, mapped onto the six moments: the aliases real
radars and their software use (each list says where its names come from), the CF and
xradar standard names, and the truth block's ``fields`` parameter, which names a field for
a moment where its name is none of these.
"""

from __future__ import annotations

from collections.abc import Mapping

from .level2 import FIELD_NAMES

#: Names a field may have in a file, per moment, in order of preference (matched without
#: regard to case). ``TH``/``DBTH`` (total power, no clutter filter) only when there is no
#: ``DBZH``; ``UPHIDP`` (unfiltered) only without ``PHIDP``. Where each name comes from:
#:
#: * ODIM_H5 quantities, as xradar's model lists them (``xradar.model.sweep_vars_mapping``)
#:   and its readers write them: ``DBZH TH DBTH ZDR UZDR RHOHV URHOHV PHIDP UPHIDP VRADH
#:   VRADDH`` (dealiased) ``WRADH UWRADH``, and ``DBZH_CLEAN`` (clutter-cleaned) from the same
#:   table; ``DBZHC`` (corrected DBZH) is the ODIM quantity that BALTRAD and IRIS-to-ODIM
#:   converters write for IRIS ``DB_DBZC``;
#: * Py-ART's field names (``pyart.config`` defaults): ``reflectivity corrected_reflectivity
#:   total_power differential_reflectivity corrected_differential_reflectivity
#:   cross_correlation_ratio differential_phase corrected_differential_phase
#:   unfolded_differential_phase velocity corrected_velocity spectrum_width``; and
#:   ``reflectivity_horizontal`` (Py-ART's own CfRadial sample files);
#: * the raw names Py-ART's readers map (``pyart.default_config``): Sigmet ``DBZ DBZC DBT
#:   VEL VELC WIDTH ZDR ZDRC RHOHV PHIDP`` (``sigmet_field_mapping``); NEXRAD ``REF VEL SW
#:   ZDR PHI RHO`` and the CDM ``Reflectivity RadialVelocity SpectrumWidth
#:   DifferentialReflectivity DifferentialPhase CorrelationCoefficient``; NCAR MDV (S-Pol)
#:   ``DBZ_F DBZ_AC VEL_F VEL_COR WIDTH_F ZDR_F RHOHV_F PHIDP_F``; RSL and UF ``DZ CZ ZE UZ
#:   VR VE SW DR ZD RH PH`` (``rsl_field_mapping``, ``uf_field_mapping``); CHL ``Z V W``;
#:   GAMIC ``Z UZ Zh UH V W`` (``gamic_field_mapping``);
#: * xradar's readers' raw names (``xradar.io.backends``): UF ``DP`` (``uf_mapping``),
#:   Datamet ``UZ CZ V W`` (``datamet_mapping``), Rainbow ``dBuZ V W`` (``rainbow_mapping``);
#: * Radx (NCAR's CfRadial writer): ``DBZ_TOT`` (total power, ``SigmetRadxFile``);
#: * ARM's CfRadial names: ``mean_doppler_velocity``, ``spectral_width``.
#:
#: Not taken: ``co_to_crosspol_correlation_coeff`` and ``crosspolar_differential_phase``
#: (an LDR radar's co- to cross-polar figures, not RHOHV and PHIDP); UF's ``ZT`` (xradar's
#: UF reader reads it as uncalibrated power, ``DBM``; Py-ART as total power).
ALIASES: dict[str, tuple[str, ...]] = {
    "DBZH": (
        "DBZH",
        "reflectivity",
        "corrected_reflectivity",
        "DBZ",
        "REF",
        "ZH",
        "CZ",
        "DZ",
        "DBZHC",
        "DBZH_CLEAN",
        "DBZC",
        "DBZ_F",
        "DBZ_AC",
        "ZE",
        "Z",
        "reflectivity_horizontal",
        "Reflectivity",
        "TH",
        "DBTH",
        "total_power",
        "DBZ_TOT",
        "DBT",
        "UZ",
        "UH",
        "dBuZ",
    ),
    "ZDR": (
        "ZDR",
        "differential_reflectivity",
        "corrected_differential_reflectivity",
        "DR",
        "ZDRC",
        "ZDR_F",
        "ZD",
        "DifferentialReflectivity",
        "UZDR",
    ),
    "RHOHV": (
        "RHOHV",
        "cross_correlation_ratio",
        "copol_correlation_coeff",
        "RHO",
        "RH",
        "RHOHV_F",
        "CorrelationCoefficient",
        "URHOHV",
    ),
    "PHIDP": (
        "PHIDP",
        "differential_phase",
        "corrected_differential_phase",
        "PHI",
        "PHIDP_F",
        "DifferentialPhase",
        "unfolded_differential_phase",
        "UPHIDP",
        "PH",
        "DP",
    ),
    "VRADH": (
        "VRADH",
        "velocity",
        "corrected_velocity",
        "VRAD",
        "VEL",
        "VR",
        "VRADDH",
        "VEL_F",
        "VELC",
        "VEL_COR",
        "VE",
        "V",
        "RadialVelocity",
        "mean_doppler_velocity",
    ),
    "WRADH": (
        "WRADH",
        "spectrum_width",
        "WRAD",
        "WIDTH",
        "SW",
        "WIDTH_F",
        "W",
        "SpectrumWidth",
        "spectral_width",
        "UWRADH",
    ),
}
#: CF / xradar standard names per moment, tried when no name matches.
STANDARD_NAMES: dict[str, tuple[str, ...]] = {
    "DBZH": ("radar_equivalent_reflectivity_factor_h", "equivalent_reflectivity_factor"),
    "ZDR": ("radar_differential_reflectivity_hv", "log_differential_reflectivity_hv"),
    "RHOHV": ("radar_correlation_coefficient_hv", "cross_correlation_ratio_hv"),
    "PHIDP": ("radar_differential_phase_hv", "differential_phase_hv"),
    "VRADH": (
        "radial_velocity_of_scatterers_away_from_instrument_h",
        "radial_velocity_of_scatterers_away_from_instrument",
    ),
    "WRADH": (
        "radar_doppler_spectrum_width_h",
        "radar_doppler_spectrum_width",
        "doppler_spectrum_width",
    ),
}


def field_map(
    names: list[str],
    standard_names: dict[str, str],
    given: Mapping[str, str] | None = None,
    where: str = "radar file",
) -> dict[str, str]:
    """moment -> the file's variable holding it: the ``given`` ones first (the truth block's
    ``fields``), then by alias (any case), then by standard name; a variable serves one
    moment. A ``given`` name the file does not have is refused, naming ``where`` (the file
    and its sweep), the moment and the file's fields."""
    lower = {n.lower(): n for n in names}
    out: dict[str, str] = {}
    for moment, name in (given or {}).items():
        found = name if name in names else lower.get(name.lower())
        if found is None:
            raise ValueError(
                f"{where}: fields maps {moment} to {name!r}, which it does not have (its "
                f"fields: {', '.join(names) or 'none'})"
            )
        out[moment] = found
    for moment in FIELD_NAMES:
        if moment in out:
            continue
        for alias in ALIASES[moment]:
            if alias.lower() in lower and lower[alias.lower()] not in out.values():
                out[moment] = lower[alias.lower()]
                break
        else:
            for name, standard in standard_names.items():
                if standard in STANDARD_NAMES[moment] and name not in out.values():
                    out[moment] = name
                    break
    return out


#: What a field's name looks like when it may hold the moment (a guess for the example in a
#: refusal or a note only; a field is never mapped by it).
_LOOKS_LIKE = {
    "DBZH": ("dbz", "refl"),
    "ZDR": ("zdr", "differential_refl"),
    "RHOHV": ("rho", "correlation"),
    "PHIDP": ("phi", "differential_phase"),
    "VRADH": ("vel", "vrad"),
    "WRADH": ("width", "wrad"),
}


def unknown_names(names: list[str], mapping: dict[str, str]) -> list[str]:
    """The fields of ``names`` that no moment was taken from and that are not a moment's
    alias either (``TH`` beside ``DBZH`` is known and left aside): the candidates for
    ``fields``."""
    known = {a.lower() for aliases in ALIASES.values() for a in aliases}
    return [n for n in names if n not in mapping.values() and n.lower() not in known]


def mapping_hint(moment: str, unknown: list[str]) -> str:
    """How to name a file's field for ``moment`` with the truth block's ``fields``
    parameter; the example is the likeliest of ``unknown`` by its name, else a placeholder."""
    likely = [n for n in unknown if any(k in n.lower() for k in _LOOKS_LIKE[moment])]
    example = likely[0] if likely else "<its name>"
    return (
        f"if one of them is {moment}, name it with the truth block's `fields` parameter: "
        f"fields: {{{moment}: {example}}} in the graph, or --set truth.fields='{{{moment}: "
        f"{example}}}'"
    )


__all__ = ["ALIASES", "STANDARD_NAMES", "field_map", "mapping_hint", "unknown_names"]
