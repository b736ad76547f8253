"""Property: whatever graph file and options it is given, ``pasim validate`` and ``pasim run``
exit 0 or 2 and never raise (no traceback).

Graph files are mutants of a tiny runnable graph (tests/fixtures/tiny_uniform.yaml: 2 beams of
8 gates and 8 pulses): lines deleted, duplicated or swapped, values replaced by random text,
numbers, nulls, lists or YAML tags, keys renamed, the text truncated, random unicode or bytes
inserted. Options are random subsets of the real ones with random values. ``pasim`` runs in
this process (``pasim_graph.cli.main``). Hypothesis runs derandomized with bounded example
counts, so CI sees the same examples every time. Inputs it found that broke ``pasim`` are kept
in tests/fixtures/refused/ and checked by tests/engine/test_cli_errors.py.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from pasim_graph import cli, registry
from pasim_graph.graphfile import read
from pasim_graph.store import LOCK, is_store, run_state

from ..conftest import FIXTURES

BASE = (FIXTURES / "tiny_uniform.yaml").read_text()
BLOCKS = re.findall(r"^  (\w+):", BASE, flags=re.M)
PARAMS = sorted({p for cls in registry.all_blocks().values() for p in cls.params})
FIELDS = ["DBZH", "ZDR", "RHOHV", "PHIDP", "VRADH", "WRADH", "SNRH", "IQ_H", "nope"]

PROFILE = settings(
    derandomize=True,
    database=None,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)

# ---- graph files --------------------------------------------------------------------------------

scalars = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(
        [
            "null",
            "~",
            "[]",
            "[1, 2]",
            "{}",
            "{a: 1}",
            "true",
            "no",
            "''",
            '"x"',
            "$frequency_hz",
            "$nope",
            "$",
            "1e400",
            "-0",
            ".inf",
            ".nan",
            "0x10",
            "1_000",
            "&a 1",
            "*a",
            "!!python/object:os.system x",
            "!!binary 3q2+7w==",
            "!!timestamp 2001-12-14",
            "!foo x",
            "|",
            "2016-06-01",
            "12:30",
            "@",
            "`",
            "%",
        ]
    ),
    st.text(max_size=12),
)
names = st.one_of(
    st.sampled_from([*BLOCKS, *PARAMS, "format", "blocks", "variables", "connections", "type"]),
    st.text(min_size=1, max_size=8),
)
_VALUE = re.compile(r"(:\s*)([^,{}\[\]\n]+)")
_KEY = re.compile(r"([A-Za-z_$][\w.$-]*)(\s*:)")


@st.composite
def mutated_graph(draw) -> bytes:
    lines = BASE.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 3))):
        n = len(lines)
        what = draw(
            st.sampled_from(["delete", "duplicate", "swap", "value", "key", "truncate", "text"])
        )
        if n == 0:
            lines = [draw(st.text(max_size=40))]
            continue
        i = draw(st.integers(0, n - 1))
        if what == "delete":
            del lines[i]
        elif what == "duplicate":
            lines.insert(draw(st.integers(0, n)), lines[i])
        elif what == "swap":
            j = draw(st.integers(0, n - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif what in ("value", "key"):
            pattern = _VALUE if what == "value" else _KEY
            found = list(pattern.finditer(lines[i]))
            if found:
                m = draw(st.sampled_from(found))
                new = draw(scalars if what == "value" else names)
                a, b = (m.start(2), m.end(2)) if what == "value" else (m.start(1), m.end(1))
                lines[i] = lines[i][:a] + new + lines[i][b:]
        elif what == "truncate":
            text = "".join(lines)
            lines = [text[: draw(st.integers(0, len(text)))]]
        else:
            text = "".join(lines)
            at = draw(st.integers(0, len(text)))
            lines = [text[:at] + draw(st.text(min_size=1, max_size=10)) + text[at:]]
    data = "".join(lines).encode("utf-8", "surrogatepass")
    if draw(st.booleans()) and draw(st.booleans()):
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=6)) + data[at:]
    return data


# ---- options ------------------------------------------------------------------------------------

sectors = st.one_of(
    st.sampled_from(
        [
            *("0:2", "-2:2", "358:2", "0:360", "10:10", "1:1.5", "a:b", "1:2:3", "nan:5"),
            *("inf:1", "-400:10", "0:720", ":", "", "5", "1e9:2"),
        ]
    ),
    st.builds(lambda a, b: f"{a}:{b}", st.floats(-400, 800), st.floats(-400, 800)),
    st.text(max_size=8),
)
overrides = st.one_of(
    st.builds(
        lambda b, p, v: f"{b}.{p}={v}",
        st.sampled_from([*BLOCKS, "nosuch"]),
        st.sampled_from(PARAMS),
        scalars,
    ),
    st.text(max_size=16),
)


def _in_bounds(block: str, param: Any) -> st.SearchStrategy[str]:
    if param.choices:
        values = st.sampled_from(param.choices)
    elif param.type == "int":
        values = st.integers(int(param.min), int(param.max))
    else:
        values = st.floats(param.min, param.max)
    return values.map(lambda v: f"{block}.{param.name}={v!r}")


# Values a parameter accepts, for every bounded parameter of the tiny graph's blocks: runs
# that validate and then exercise the blocks at odd settings.
_SPEC = read(FIXTURES / "tiny_uniform.yaml")
accepted = st.one_of(
    [
        _in_bounds(name, p)
        for name, b in _SPEC.blocks.items()
        for p in registry.get(b.type).params.values()
        if p.choices or (p.type in ("int", "float") and None not in (p.min, p.max))
    ]
)
numbers = st.one_of(st.integers(-3, 2**70).map(str), st.text(max_size=6))


def _option(name: str, values: st.SearchStrategy[str]) -> st.SearchStrategy[list[str]]:
    return st.one_of(
        values.map(lambda v: [name, v]),
        values.map(lambda v: [f"{name}={v}"]),
        st.just([name]),  # value missing
    )


GRAPH_OPTIONS = [
    _option("--sector", sectors),
    _option("--set", overrides),
    _option("--truth", st.sampled_from(["/no/such/file", "/tmp", str(FIXTURES), "", "-"])),
]
RUN_OPTIONS = [
    *GRAPH_OPTIONS,
    accepted.map(lambda v: ["--set", v]),
    accepted.map(lambda v: ["--set", v]),
    _option("--seed", numbers),
    _option("--chunk", numbers),
    _option("--outputs", st.lists(st.sampled_from(FIELDS), max_size=3).map(",".join)),
    _option("--scheduler", st.sampled_from(["threads", "sync", "tcp://127.0.0.1:1", "x", ""])),
    # A valid count would start a cluster of processes: only refused values here.
    _option("--workers", st.sampled_from(["0", "-1", "two", ""])),
    st.sampled_from([["--save-iq"], ["--overwrite"], ["--resume"], ["--progress"], ["--zzz"]]),
]


def option_lists(choices: list[st.SearchStrategy[list[str]]]) -> st.SearchStrategy[list[str]]:
    return st.lists(st.one_of(choices), max_size=4).map(lambda xs: [a for x in xs for a in x])


# ---- running pasim ------------------------------------------------------------------------------


def pasim(argv: list[str]) -> int:
    """Exit code of ``pasim ARGV`` run here; any exception but argparse's exit propagates."""
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        try:
            return cli.main(argv)
        except SystemExit as exc:
            return int(exc.code or 0)


def _small(argv: list[str]) -> bool:
    """False for a run that would validate and is too big to run in a property test.

    Runs refused before they start cost nothing and are all kept; valid ones are kept when
    every size the tiny graph can grow in (beams, gates, pulses, truth radials, pattern grid,
    pulse samples, drops) stays small.
    """
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            args = cli.parser().parse_args(cli._join_negative_values(argv))
        graph = cli.load_graph(args)
        return _sizes_small(graph)
    except BaseException:  # refused before any work (or raising, which main will show)
        return True


def _sizes_small(graph) -> bool:
    size: dict[str, float] = {"beams": 1, "radials": 1, "grid": 1, "samples": 1}
    for name, cls in graph.classes.items():
        value = {p: graph.value(name, p) for p in cls.params}
        if cls.beam_source:
            size["beams"] = cls(name=name, **graph.params[name]).beam_count()
        if "radial_width_deg" in value:
            size["radials"] = value["gates"] * 360 / value["radial_width_deg"]
        if "grid_step_deg" in value:
            size["grid"] = (2 * value["support_deg"] / value["grid_step_deg"]) ** 2
        if "sample_rate_hz" in value:
            size["samples"] = value["width_s"] * value["sample_rate_hz"]
        if value.get("method") in ("covariance", "monte_carlo"):
            size["method"] = 1e9  # the tiny graph runs "combined"; the others cost more
        if "pulses" in value:
            size["pulses"] = value["pulses"]
    limits = {"beams": 8, "radials": 720 * 64, "grid": 1e5, "samples": 1e3, "pulses": 64}
    return all(size.get(k, 0) <= v for k, v in limits.items()) and "method" not in size


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("property")


@settings(PROFILE, max_examples=300)
@given(graph=mutated_graph(), options=option_lists([*GRAPH_OPTIONS, st.just(["--json"])]))
def test_validate_exits_0_or_2(workdir, graph, options):
    path = workdir / "mutant.yaml"
    path.write_bytes(graph)
    code = pasim(["validate", str(path), *options])
    event(f"exit {code}")
    assert code in (0, 2)


_runs = itertools.count()


@settings(PROFILE, max_examples=40)
@given(
    graph=st.one_of(st.just(BASE.encode()), mutated_graph()),
    options=option_lists(RUN_OPTIONS),
)
def test_run_exits_0_or_2_and_leaves_no_wrong_store(workdir, graph, options):
    path = workdir / "mutant.yaml"
    path.write_bytes(graph)
    out = workdir / f"run{next(_runs)}.zarr"
    argv = ["run", str(path), *options, "--out", str(out)]
    assume(_small(argv))
    code = pasim(argv)
    event(f"exit {code}")
    assert code in (0, 2)
    if out.exists():
        assert is_store(out) and not (out / LOCK).exists()
        state = run_state(out)
        complete = state is not None and state[0].get("pasim_complete") == "true"
        # A store says it is complete only when its run succeeded.
        assert complete == (code == 0)
    else:
        assert code == 2
