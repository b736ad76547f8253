"""xarray's pint look-up deferred (pasim_graph/duck_arrays.py): a run imports no pint, and a
program that uses pint arrays sees xarray treat them as xarray itself does."""

from __future__ import annotations

import subprocess
import sys

CHECK = """
import sys
import numpy as np
import pasim_graph.executor  # defers the look-up, as every run and Dask worker does
import xarray as xr
from xarray.namedarray import pycompat

da = xr.DataArray(np.arange(4.0), dims="x", coords={"x": np.arange(4)})
da.sel(x=2).values, da.to_numpy(), pycompat.to_numpy(da.variable.data)
assert "pint" not in sys.modules, "xarray imported pint"
assert pycompat.array_type("pint") == ()

import pint

q = pint.UnitRegistry().Quantity(np.ones(3), "m")
# xarray's own answers once pint is imported: the Quantity's class, its version, and the
# Quantity kept as a duck array (to_numpy strips it to its magnitude).
assert pycompat.array_type("pint") == (pint.Quantity,) and isinstance(q, pint.Quantity)
assert str(pycompat.mod_version("pint")) == pint.__version__
assert isinstance(xr.DataArray(q, dims="y").data, type(q))
np.testing.assert_array_equal(pycompat.to_numpy(q), np.ones(3))
assert isinstance(pycompat.to_numpy(q), np.ndarray)
print("ok")
"""


def test_a_run_imports_no_pint_and_pint_arrays_stay_pint_arrays():
    """Independent reference: xarray's documented duck-array handling of pint Quantities
    (kept as the variable's data, stripped to the magnitude by to_numpy)."""
    res = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr
