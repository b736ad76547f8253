"""The flat module paths of the block library before it was cut into subsystem packages.

``pasim_blocks.antenna``, ``pasim_blocks.weather``, ... are kept for one release: each old
module still imports (made on the fly by :class:`OldPathFinder`, so no file of it is left in
the package) and each of its names still resolves, with a :class:`DeprecationWarning` naming
the module that now holds it. :data:`MOVED` maps each old module to its new ones.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import types
import warnings
from collections.abc import Callable
from typing import Any

#: Old flat module -> the modules that now hold its names, searched in order.
MOVED: dict[str, tuple[str, ...]] = {
    "pasim_blocks.waveform": ("pasim_blocks.waveforms.pulses",),
    "pasim_blocks.nlfm": ("pasim_blocks.waveforms.nlfm",),
    "pasim_blocks.compression": ("pasim_blocks.waveforms.compression",),
    "pasim_blocks.amplifier": ("pasim_blocks.transmitters.amplifiers",),
    "pasim_blocks.jitter": ("pasim_blocks.transmitters.jitter",),
    "pasim_blocks.antenna": (
        "pasim_blocks.antennas.base",
        "pasim_blocks.antennas.pencil",
        "pasim_blocks.antennas.array",
        "pasim_blocks.antennas.planar",
    ),
    "pasim_blocks.cylindrical": ("pasim_blocks.antennas.cylindrical",),
    "pasim_blocks.elements": ("pasim_blocks.antennas.elements",),
    "pasim_blocks.electronics": ("pasim_blocks.antennas.electronics",),
    "pasim_blocks.measured_pattern": (
        "pasim_blocks.antennas.measured",
        "pasim_blocks.antennas.pattern_files",
    ),
    "pasim_blocks.patterns": (
        "pasim_blocks.antennas.aperture",
        "pasim_blocks.antennas.geometry",
        "pasim_blocks.antennas.tapers",
        "pasim_blocks.antennas.array_factor",
        "pasim_blocks.antennas.measures",
        "pasim_blocks.signals",
    ),
    "pasim_blocks.truth": ("pasim_blocks.truth.nexrad",),
    "pasim_blocks.scene": ("pasim_blocks.truth.scenes",),
    "pasim_blocks.nexrad_io": ("pasim_blocks.truth.nexrad_io",),
    "pasim_blocks.scan": ("pasim_blocks.scans.ppi",),
    "pasim_blocks.weather": (
        "pasim_blocks.weather.channel",
        "pasim_blocks.weather.beams",
        "pasim_blocks.weather.cells",
        "pasim_blocks.weather.spectra",
    ),
    "pasim_blocks.fasttime": ("pasim_blocks.weather.fasttime",),
    "pasim_blocks.polarimetry": ("pasim_blocks.weather.polarimetry",),
    "pasim_blocks.receiver": ("pasim_blocks.receivers.receiver",),
    "pasim_blocks.matched_filter": ("pasim_blocks.receivers.filters",),
    "pasim_blocks.ppp": ("pasim_blocks.processing.pulse_pair",),
    "pasim_blocks.scorer": ("pasim_blocks.processing.scorer",),
    "pasim_blocks.waveform_command": ("pasim_blocks.commands.waveform",),
    "pasim_blocks.pattern_command": ("pasim_blocks.commands.pattern",),
}

#: Old modules whose path is now a subpackage: importing the package must not warn, so
#: these warn when one of the old module's names is looked up on the package.
PACKAGES = frozenset({"pasim_blocks.truth", "pasim_blocks.weather"})


def find(old: str, name: str) -> tuple[str, Any]:
    """The new module holding ``name`` of the old module ``old``, and its value."""
    for new in MOVED[old]:
        value = vars(importlib.import_module(new)).get(name, _MISSING)
        if value is not _MISSING and not isinstance(value, types.ModuleType):
            return new, value
    raise AttributeError(f"module {old!r} has no attribute {name!r}")


def warn(old: str, new: str) -> None:
    warnings.warn(
        f"{old} is deprecated and will be removed in the next release: import from {new}",
        DeprecationWarning,
        stacklevel=3,
    )


def forward(old: str) -> Callable[[str], Any]:
    """The module ``__getattr__`` of an old flat module (it warns once, on import)."""
    if old not in PACKAGES:
        warn(old, " or ".join(MOVED[old]))

    def __getattr__(name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        new, value = find(old, name)
        if old in PACKAGES:
            warn(f"{old}.{name}", new)
        return value

    return __getattr__


class OldPathFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an old flat module path as a module that forwards to the new ones."""

    def find_spec(
        self, fullname: str, path: Any = None, target: Any = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname in MOVED and fullname not in PACKAGES:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: types.ModuleType) -> None:
        module.__doc__ = f"Deprecated: moved to {', '.join(MOVED[module.__name__])}."
        module.__getattr__ = forward(module.__name__)  # type: ignore[method-assign]


def install() -> None:
    """Let the old flat module paths import (once per interpreter)."""
    if not any(isinstance(f, OldPathFinder) for f in sys.meta_path):
        sys.meta_path.append(OldPathFinder())


_MISSING = object()
