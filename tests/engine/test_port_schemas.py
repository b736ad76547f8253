"""Typed Dataset payloads: schemas on every edge, every block's outputs held to them.

Unit tests of :class:`Schema` (``feeds`` at validation, ``check`` at run time),
:meth:`PortType.check` and :meth:`PortType.mismatch`; a block declaring a Dataset port without
a schema is a validation problem; every library block, on every graph of graphs/, returns what
it declares (the executor's check runs on each of them); a plugin block returning a misspelt
variable stops the run at that block; ``pasim blocks`` shows units, bounds and schemas.
"""

from __future__ import annotations

import argparse
import fcntl
import hashlib
import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from threadpoolctl import threadpool_info, threadpool_limits

from pasim_graph import (
    DATASET,
    Attr,
    Block,
    GraphError,
    Output,
    PortType,
    Schema,
    Var,
    cli,
    executor,
    registry,
)
from pasim_graph.executor import LocalExecutor, RunOptions
from pasim_graph.graph import validate
from pasim_graph.graphfile import dumps, read

from ..conftest import FIXTURES, GRAPHS, pasim_result, run_cli
from .test_plugin import plugin_env  # noqa: F401  (the plugin package, pip-installed)

SCHEMA = Schema(
    {
        "power": Var("float32", ("beam", "range"), "W", "echo power"),
        "snr": Var("floating", ("beam", "range"), "dB", "SNR", required=False),
        "range": Var("float64", ("range",), "meters", "gate ranges"),
    },
    {"prt_s": Attr("float", "PRT"), "note": Attr("str", "free text", required=False)},
)


def dataset(**change: Any) -> xr.Dataset:
    """A Dataset that fits SCHEMA, with ``change`` applied (name -> Variable, or None)."""
    ds = xr.Dataset(
        {
            "power": (("beam", "range"), np.ones((2, 3), np.float32), {"units": "W"}),
            "snr": (("beam", "range"), np.zeros((2, 3)), {"units": "dB"}),
        },
        coords={"range": ("range", np.arange(3.0), {"units": "meters"})},
        attrs={"prt_s": 1e-3, "note": "x"},
    )
    for name, var in change.items():
        ds = ds.drop_vars(name) if var is None else ds.assign({name: var})
    return ds


# ---- Schema.check: what a block returned -------------------------------------------------------


def test_a_dataset_that_fits_has_no_problem():
    assert SCHEMA.check(dataset()) == []
    assert SCHEMA.check(dataset(snr=None)) == []  # optional variable absent
    ds = dataset()
    del ds.attrs["note"]
    ds.attrs["provenance"] = "anything"  # undeclared attributes are allowed
    assert SCHEMA.check(ds) == []


def test_missing_required_and_undeclared_variables_are_named():
    problems = SCHEMA.check(dataset(power=None, extra=(("beam",), np.ones(2), {"units": ""})))
    assert "required variable 'power' (float32 (beam, range) W) is missing" in problems
    assert any(
        p.startswith("variable 'extra' is not declared (declared: power, snr") for p in problems
    )


def test_misspelt_variable_names_the_one_it_stands_for():
    ds = dataset().rename({"power": "powr"})
    (undeclared, missing) = SCHEMA.check(ds)
    assert "'powr' is not declared" in undeclared and "misspelling of 'power'" in undeclared
    assert "required variable 'power'" in missing


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"power": (("beam", "range"), np.ones((2, 3)), {"units": "W"})}, "dtype float64"),
        ({"power": (("range", "beam"), np.ones((3, 2), np.float32), {"units": "W"})}, "dims"),
        ({"power": (("beam", "range"), np.ones((2, 3), np.float32), {"units": "mW"})}, "'mW'"),
        ({"power": (("beam", "range"), np.ones((2, 3), np.float32))}, "units ''"),
        ({"snr": (("beam", "range"), np.zeros((2, 3), np.int16), {"units": "dB"})}, "int16"),
    ],
    ids=["dtype", "dims", "units", "no units", "family"],
)
def test_mistyped_variable_is_named(change, expected):
    problems = SCHEMA.check(dataset(**change))
    assert len(problems) == 1 and expected in problems[0], problems


@pytest.mark.parametrize(
    ("family", "good", "bad"),
    [
        ("floating", [np.float16, np.float32, np.float64], [np.int32, np.complex64]),
        ("complexfloating", [np.complex64, np.complex128], [np.float64]),
        ("integer", [np.int8, np.int64, np.uint16], [np.float32, np.bool_]),
        ("bool", [np.bool_], [np.int8]),
        ("str", ["U3", object], [np.int64, "S3"]),
        ("datetime64", ["datetime64[ns]", "datetime64[s]"], ["timedelta64[ns]", np.int64]),
    ],
)
def test_dtype_families(family, good, bad):
    schema = Schema({"x": Var(family, ("n",))})
    for dtype in good:
        values = np.array(["a", "b"], dtype=dtype) if family == "str" else np.zeros(2, dtype)
        ds = xr.Dataset({"x": ("n", values)})
        assert schema.check(ds) == [], dtype
    for dtype in bad:
        ds = xr.Dataset({"x": ("n", np.zeros(2, dtype))})
        assert schema.check(ds) == [f"variable 'x' has dtype {np.dtype(dtype)}, declared {family}"]


def test_attributes_required_and_typed():
    ds = dataset()
    del ds.attrs["prt_s"]
    assert SCHEMA.check(ds) == ["required attribute 'prt_s' (float) is missing"]
    for value, found in [("1e-3", "str '1e-3'"), (True, "bool True"), ([1], "list [1]")]:
        ds.attrs["prt_s"] = value
        assert SCHEMA.check(ds) == [f"attribute 'prt_s': expected float, found {found}"]
    ds.attrs["prt_s"] = np.float32(1e-3)  # numpy scalars are numbers
    ds.attrs["note"] = 3
    assert SCHEMA.check(ds) == ["attribute 'note': expected str, found int 3"]
    assert Attr("int").check(np.int64(2)) is None and Attr("int").check(2.0) is not None


# ---- Schema.feeds and PortType.mismatch: an edge at validation ------------------------------


def test_feeds_requires_what_the_input_needs_always_provided():
    out = Schema(
        {"a": Var("float32", ("n",), "W"), "b": Var("float32", ("n",), "W", required=False)}
    )
    assert out.feeds(Schema({"a": Var("float32", ("n",), "W")})) == []
    # An input may need less than the output gives, and may leave optional variables out.
    assert out.feeds(Schema({"c": Var("float32", ("n",), required=False)})) == []
    assert out.feeds(Schema({"c": Var("float32", ("n",))})) == [
        "variable 'c' (float32 (n)) is not provided"
    ]
    assert out.feeds(Schema({"b": Var("float32", ("n",), "W")})) == [
        "variable 'b' is needed but only sometimes provided"
    ]


def test_feeds_compares_dtype_dims_and_units():
    out = Schema({"a": Var("float32", ("n",), "W")})
    # A family accepts its members; a member does not accept the whole family.
    assert out.feeds(Schema({"a": Var("floating", ("n",), "W")})) == []
    wide = Schema({"a": Var("floating", ("n",), "W")})
    assert wide.feeds(Schema({"a": Var("float32", ("n",), "W")})) == [
        "variable 'a': dtype floating vs float32"
    ]
    assert out.feeds(Schema({"a": Var("int32", ("m",), "dB")})) == [
        "variable 'a': dtype float32 vs int32; dims (n) vs (m); units 'W' vs 'dB'"
    ]


def test_feeds_requires_attributes_always_provided():
    into = Schema({}, {"prt_s": Attr("float")})
    assert Schema({}, {"prt_s": Attr("float")}).feeds(into) == []
    assert Schema({}, {"prt_s": Attr("float", required=False)}).feeds(into) == [
        "attribute 'prt_s' (float) is not always provided"
    ]
    assert Schema({}).feeds(into) == ["attribute 'prt_s' (float) is not always provided"]
    assert Schema({}).feeds(Schema({}, {"x": Attr("str", required=False)})) == []


def test_mismatch_checks_the_type_then_the_schema():
    a = PortType("moments", DATASET, ("beam", "range"), "cfradial", SCHEMA)
    assert a.mismatch(a) == []
    b = PortType("iq", "complex64", ("beam",), "sqrt(W)")
    assert a.mismatch(b) == [
        "kind 'moments' vs 'iq'",
        "dtype 'dataset' vs 'complex64'",
        "dims (beam, range) vs (beam)",
        "units 'cfradial' vs 'sqrt(W)'",
    ]
    needs_more = Schema({**SCHEMA.variables, "vel": Var("float32", ("beam", "range"), "m s-1")})
    c = PortType("moments", DATASET, ("beam", "range"), "cfradial", needs_more)
    assert a.mismatch(c) == ["variable 'vel' (float32 (beam, range) m s-1) is not provided"]


def test_port_type_check_of_arrays_and_datasets():
    iq = PortType("iq", "complex64", ("beam", "range"), "sqrt(W)")
    assert iq.check(np.zeros((2, 3), np.complex64)) == []
    assert iq.check(np.zeros((2, 3), np.complex128)) == ["dtype complex128, declared complex64"]
    assert iq.check(np.zeros(3, np.complex64)) == ["1 dimensions, declared 2 (beam, range)"]
    assert iq.check([1, 2]) == ["expected a numpy array of complex64, found list"]
    moments = PortType("moments", DATASET, ("beam", "range"), "cfradial", SCHEMA)
    assert moments.check(np.zeros(2)) == ["expected an xarray.Dataset, found ndarray"]
    assert moments.check(dataset()) == []
    assert moments.check(dataset(power=None)) == SCHEMA.check(dataset(power=None)) != []


# ---- declarations -------------------------------------------------------------------------------


class _SchemalessOut(Block):
    """A faulty declaration: a Dataset output without a schema."""

    beams = Output(PortType("beams", DATASET, ("beam",), "deg"), doc="no schema")
    fields_out = Output(
        PortType("moments", DATASET, ("beam",), "cfradial", Schema({"A": Var("float32")})),
        fields=("A", "B"),
    )


def test_interface_problems_name_the_port():
    problems = dict(_SchemalessOut.interface_problems())
    assert problems == {
        "port 'beams'": "output carries a dataset but declares no schema",
        "port 'fields_out'": "fields B are not variables of its schema",
    }


def test_faulty_declaration_is_a_validation_problem(monkeypatch):
    monkeypatch.setitem(registry._loaded, "test.schemaless", _SchemalessOut)
    spec = read(FIXTURES / "tiny_uniform.yaml")
    spec.blocks["odd"] = type(spec.blocks["mf"])("test.schemaless", line=99)
    with pytest.raises(GraphError) as info:
        validate(spec)
    text = str(info.value)
    assert "block 'odd', port 'beams': block type test.schemaless is faulty" in text
    assert "output carries a dataset but declares no schema" in text


def test_every_library_port_declares_its_schema():
    blocks = registry.all_blocks()
    library = {n: c for n, c in blocks.items() if c.__module__.startswith("pasim_blocks.")}
    assert len(library) >= 16
    for name, cls in library.items():
        assert cls.interface_problems() == [], name


# ---- what every library block returns -------------------------------------------------------


def _graph_variants() -> list[tuple[str, Any, RunOptions]]:
    """Each graph of graphs/ on two beams of eight pulses, plus the block types and levels no
    graph uses: the ideal amplifier, every weather fidelity level, one field only."""
    out = []
    for path in sorted(GRAPHS.glob("*.yaml")):
        if path.name.endswith("_study.yaml"):
            continue  # a study file, not a graph (tests/study/test_study_files.py)
        out.append((path.stem, path, RunOptions(save_iq=True, chunk_beams=2)))
    uniform = GRAPHS / "uniform_ideal.yaml"
    for method in ("expected", "combined", "monte_carlo"):
        sets = [f"weather.method={method}", "weather.drops_per_cell=4"]
        # The expected level draws no pulses: --save-iq is refused there
        # (tests/engine/test_cli_errors.py).
        options = RunOptions(save_iq=method != "expected")
        out.append((f"uniform-{method}", (uniform, sets), options))
    out.append(("uniform-DBZH", uniform, RunOptions(fields=("DBZH",))))
    spec = read(GRAPHS / "generic_radar.yaml")
    spec.blocks["hpa"] = type(spec.blocks["hpa"])("amplifier.ideal")
    out.append(("generic-ideal-amplifier", dumps(spec), RunOptions()))
    return out


@pytest.mark.parametrize(
    ("label", "source", "options"), [pytest.param(*v, id=v[0]) for v in _graph_variants()]
)
def test_library_blocks_return_what_they_declare(label, source, options, tmp_path, monkeypatch):
    """LocalExecutor checks every value a block returns against its output ports; each block
    of the graph is checked (counted), and none fails."""
    sets, more = ["scan.pulses=8"], []
    if isinstance(source, tuple):
        source, more = source
    if isinstance(source, str):
        path = tmp_path / "graph.yaml"
        path.write_text(source)
        source = path
    # Two beams of eight pulses, however the scan defines its beams.
    spec = read(source)
    scan = spec.blocks["scan"].type
    # The first two degrees of the graph's own sector (an array's face points there).
    start = float(spec.blocks["scan"].params.get("azimuth_start_deg", 280.0))
    sector: str | None = f"{start:g}:{start + 2:g}"
    if scan == "scan.rhi":
        sets, sector = [*sets, "scan.elevation_stop_deg=1.0"], None
    elif scan == "scan.schedule":
        beams = tmp_path / "beams.csv"
        beams.write_text("azimuth_deg,elevation_deg,pulses,prt_s\n280,0.5,8,0.001\n281,1,8,0.001\n")
        sets, sector = [f"scan.path={beams}"], None
    args = argparse.Namespace(graph=str(source), truth=None, sector=sector, set=sets + more)
    graph = cli.load_graph(args)
    checked: dict[str, int] = {}
    real = executor._check_outputs

    def counting(cls: type[Block], out: Any) -> None:
        real(cls, out)
        checked[cls.type_name] = checked.get(cls.type_name, 0) + 1

    monkeypatch.setattr(executor, "_check_outputs", counting)
    ex = LocalExecutor(graph, options)
    # One BLAS thread: a product's rounding depends on how many threads split it, and the
    # fingerprint below must not depend on the machine's thread count.
    with threadpool_limits(limits=1, user_api="blas"):
        sweep = ex.run()
    assert set(checked) == {type(b).type_name for b in ex.plan.blocks.values()}, label
    assert sweep.sizes["beam"] == 2
    if options.fields == ("DBZH",):
        assert "DBZH" in sweep and "VRADH" not in sweep
    check_fingerprint(label, sweep)


#: Each graph's numbers on its two beams, as a digest of every stored value (tests/
#: fingerprints.json): a change of layout or a refactor must leave every number to the bit;
#: a change of physics rewrites them on purpose (PASIM_UPDATE_FINGERPRINTS=1) and the diff
#: shows which graphs it moved.
FINGERPRINTS = Path(__file__).parents[1] / "fingerprints.json"


def fingerprint(sweep: Any) -> str:
    digest = hashlib.sha256()
    for name in sorted(sweep.variables):
        values = np.asarray(sweep[name].values)
        if values.dtype.kind in "fc":
            values = np.where(np.isnan(values), np.nan, values)  # one NaN pattern
        digest.update(f"{name}:{values.dtype.str}:{values.shape}".encode())
        digest.update(
            np.ascontiguousarray(values).tobytes()
            if values.dtype.kind != "O"
            else repr(values.tolist()).encode()
        )
    return digest.hexdigest()[:24]


#: The kernels the fingerprints were recorded under: the last bits of every number depend on
#: them (tests/conftest.py pins them for the suite's processes on an x86-64 with AVX2).
RECORDED_NUMERICS = "NumPy X86_V3, OpenBLAS Haswell"


def numerics() -> str:
    """The SIMD kernels this process's NumPy dispatches to and the cores its OpenBLAS uses."""
    from numpy.lib.introspect import opt_func_info

    targets = {t["current"] for kinds in opt_func_info().values() for t in kinds.values()}
    blas = {i.get("architecture") for i in threadpool_info() if i["internal_api"] == "openblas"}
    return (
        f"NumPy {'+'.join(sorted(t for t in targets if not t.startswith('baseline')))}, "
        f"OpenBLAS {'+'.join(sorted(map(str, blas)))}"
    )


def check_fingerprint(label: str, sweep: Any) -> None:
    here = numerics()
    if here != RECORDED_NUMERICS:
        if os.environ.get("OPENBLAS_CORETYPE") == "Haswell":
            pytest.fail(
                f"this process runs {here}, not the {RECORDED_NUMERICS} that tests/conftest.py "
                "pins: NPY_DISABLE_CPU_FEATURES set otherwise, or NumPy imported before the pin (a "
                "pytest plugin? see pyproject's addopts)"
            )
        pytest.skip(f"fingerprints are of {RECORDED_NUMERICS}; this machine runs {here}")
    value = fingerprint(sweep)
    if os.environ.get("PASIM_UPDATE_FINGERPRINTS"):
        # Test workers (pytest-xdist) may record at once: one at a time through a file lock.
        with open(FINGERPRINTS.with_suffix(".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            known = json.loads(FINGERPRINTS.read_text()) if FINGERPRINTS.exists() else {}
            known[label] = value
            FINGERPRINTS.write_text(json.dumps(dict(sorted(known.items())), indent=1) + "\n")
        return
    known = json.loads(FINGERPRINTS.read_text())
    assert label in known, f"{label}: no fingerprint (PASIM_UPDATE_FINGERPRINTS=1 records it)"
    assert known[label] == value, (
        f"{label}: its numbers changed (fingerprint {value}, recorded {known[label]}); if the "
        "change is meant, rerun with PASIM_UPDATE_FINGERPRINTS=1 and say why in the commit"
    )


def test_misspelt_variable_stops_the_run_at_its_block(plugin_env, tmp_path):  # noqa: F811
    """The plugin block renames DBZH to DBZ: the run fails at that block, naming the port,
    the undeclared DBZ and the missing DBZH, and not in the scorer that reads it."""
    graph = FIXTURES / "misspelt_moments.yaml"
    res = run_cli("validate", str(graph), env=plugin_env)
    assert res.returncode == 0, res.stderr  # the declarations are right; the values are not
    out = tmp_path / "x.zarr"
    res = run_cli("run", str(graph), "--out", str(out), env=plugin_env)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    err = res.stderr
    assert "block 'misspelt' (example.misspelt_moments) failed on beams 0-0" in err
    assert "PortValueError: output port 'moments': variable 'DBZ' is not declared" in err
    assert "a misspelling of 'DBZH', which is missing?" in err
    assert "scorer" not in err
    assert not out.exists()


# ---- pasim blocks ---------------------------------------------------------------------------


def test_blocks_text_shows_units_bounds_and_schemas(capsys):
    res = pasim_result(capsys, "blocks")
    assert res.returncode == 0, res.stderr
    text = res.stdout
    sections = dict(re.findall(r"^(\S+)  \(\w+\) .*?\n((?:    .*\n)*)", text, flags=re.M))
    library = {n: c for n, c in registry.all_blocks().items() if n in sections}
    assert len(library) >= 16
    for name, cls in library.items():
        lines = sections[name].splitlines()
        for p in cls.params.values():
            (line,) = [x for x in lines if x.startswith(f"    param {p.name} = ")]
            if p.units:
                assert f" {p.units} " in line, line
            if p.min is not None and p.max is not None:
                assert f"({p.min:g} to {p.max:g}" in line, line
            elif p.min is not None:
                assert f">= {p.min:g}" in line, line
            if p.doc:
                assert line.endswith(p.doc), line
        for port in [*cls.inputs.values(), *cls.outputs.values()]:
            if port.type.schema is None:
                continue
            for var, decl in port.type.schema.variables.items():
                described = f"{var}: {decl.describe()}"
                assert any(x.strip().startswith(described) for x in lines), (name, var)
            for attr, decl in port.type.schema.attrs.items():
                assert any(x.strip().startswith(f"@{attr}: {decl.type}") for x in lines)
    # The moments as a user reads them: units and dims of one variable, bounds of a parameter.
    assert "DBZH: float32 (beam, range) dBZ (optional)  reflectivity factor, H" in text
    assert "azimuth_start_deg = 240.0 deg float (0 to 360 deg)" in text
