"""xarray's look-up of pint, deferred until pint is imported.

xarray asks, whenever it turns data into numpy (``to_numpy``: every index, every ``.values``
of some variables), whether the data is a pint ``Quantity``; to find the class it imports
pint the first time, if pint is installed at all. arm-pyart installs pint, so every ``pasim``
process and every Dask worker paid pint's import (0.9 s of CPU, measured 2026-11-28) for a
question whose answer is known without it: no value can be a ``Quantity`` while pint has not
been imported. :func:`defer_pint_lookup` puts an entry in xarray's cache that answers "no
pint type" until pint is imported (by anyone), and xarray's own answer from then on, so a
program that does use pint arrays sees xarray behave exactly as before.
"""

from __future__ import annotations

import sys
from typing import Any


class _DeferredPint:
    """Stands in for xarray's ``DuckArrayModule("pint")``: its ``type`` is empty until pint
    is imported; then (and for any other attribute) xarray's own entry, which replaces this
    one in the cache."""

    def __init__(self, cache: dict[str, Any], make: Any):
        self._cache, self._make = cache, make

    def _entry(self) -> Any:
        entry = self._make("pint")
        self._cache["pint"] = entry
        return entry

    @property
    def type(self) -> tuple[type, ...]:
        if "pint" not in sys.modules:
            return ()
        return self._entry().type

    def __getattr__(self, name: str) -> Any:  # module, version, available: xarray's answer
        return getattr(self._entry(), name)


def defer_pint_lookup() -> None:
    """Make xarray find pint's array type only once pint has been imported (see the module's
    docstring). Does nothing where xarray keeps no such cache or pint is already imported."""
    try:
        from xarray.namedarray import pycompat
    except ImportError:  # pragma: no cover (an xarray without the module: nothing to defer)
        return
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    make = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or make is None or "pint" in sys.modules:
        return
    cache.setdefault("pint", _DeferredPint(cache, make))
