"""The graph text format: parsing, canonical writing, round trips."""

from __future__ import annotations

from pasim_graph.graphfile import FORMAT, dumps, parse

TEXT = """\
format: pasim-graph/1
variables: {prt_s: 3.333e-3, f: 1e9}
blocks:
  tx:  {type: waveform.rectangular, params: {width_s: 1.6e-6}}
  hpa: {type: amplifier.saleh}
connections:
  - tx.pulse -> hpa.pulse_in
  - tx -> hpa
"""


def test_parse_reads_names_values_and_lines():
    spec = parse(TEXT, "g.yaml")
    assert spec.problems == []
    assert spec.format == FORMAT
    # YAML 1.1 would read 1e9 and 1.6e-6 as strings; the loader reads them as numbers.
    assert spec.variables == {"prt_s": 3.333e-3, "f": 1e9}
    assert spec.blocks["tx"].params == {"width_s": 1.6e-6}
    assert spec.blocks["hpa"].line == 5
    c = spec.connections[1]
    assert (c.src.block, c.src.port, c.dst.block, c.dst.port, c.line) == (
        "tx",
        None,
        "hpa",
        None,
        8,
    )


def test_dump_is_canonical_and_round_trips():
    spec = parse(TEXT)
    text = dumps(spec)
    again = dumps(parse(text))
    assert text == again
    lines = text.splitlines()
    assert lines[0] == "format: pasim-graph/1"
    # Blocks sorted by name, connections sorted.
    tx_line = next(i for i, s in enumerate(lines) if s.startswith("  tx:"))
    assert lines.index("  hpa: {type: amplifier.saleh}") < tx_line
    assert lines[-2:] == ["  - tx -> hpa", "  - tx.pulse -> hpa.pulse_in"]


def test_strings_that_look_like_numbers_stay_strings():
    spec = parse('format: pasim-graph/1\nblocks:\n  a: {type: x, params: {name: "1e5"}}\n')
    assert spec.blocks["a"].params["name"] == "1e5"
    assert parse(dumps(spec)).blocks["a"].params["name"] == "1e5"


def test_malformed_yaml_reports_line():
    spec = parse("format: pasim-graph/1\nblocks:\n  a: {type: x\n  ]]]\n", "bad.yaml")
    assert len(spec.problems) == 1
    p = spec.problems[0]
    assert p.file == "bad.yaml" and p.line >= 3 and "malformed YAML" in p.message


def test_bad_connection_text_is_a_problem():
    spec = parse("format: pasim-graph/1\nblocks: {}\nconnections:\n  - a.b => c\n")
    assert any("cannot read connection" in p.message and p.line == 4 for p in spec.problems)
