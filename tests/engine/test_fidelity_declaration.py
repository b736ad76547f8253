"""The fidelity level is declared by the block that has one (``Block.fidelity_param`` and
``Block.expected_level``), checked against the block's own parameters at validation, and the
study's reference runs read the declaration, not a parameter's name."""

from __future__ import annotations

from typing import ClassVar

from pasim_blocks.study.plan import expected_overrides
from pasim_blocks.weather.channel import WeatherChannel

from pasim_graph import Block, Param, load

from ..conftest import GRAPHS


class Leveled(Block):
    """A fidelity parameter that is not called ``method``, beside a ``method`` that is not one."""

    level = Param("full", type="str", choices=("noise_free", "full"), doc="fidelity")
    method = Param("a", type="str", choices=("a", "expected"), doc="not a fidelity level")
    fidelity_param: ClassVar[str] = "level"
    expected_level: ClassVar[str] = "noise_free"


class WrongLevel(Leveled):
    expected_level: ClassVar[str] = "expected"


class NoSuchParameter(Leveled):
    fidelity_param: ClassVar[str] = "precision"


def test_the_weather_channel_declares_its_levels() -> None:
    assert WeatherChannel.fidelity_param == "method"
    assert WeatherChannel.expected_level in WeatherChannel.params["method"].choices
    assert WeatherChannel.interface_problems() == []
    assert Leveled.interface_problems() == []


def test_a_declaration_the_parameters_do_not_back_is_a_problem() -> None:
    assert WrongLevel.interface_problems() == [
        ("expected_level", "'expected' is not a choice of parameter 'level'")
    ]
    assert NoSuchParameter.interface_problems() == [
        ("fidelity_param", "'precision' is not a parameter of the block")
    ]


def test_the_study_reads_the_declaration_not_the_name(monkeypatch) -> None:
    graph = load(GRAPHS / "generic_radar.yaml")
    assert expected_overrides(graph) == {"weather.method": "expected"}
    # A block with a parameter named 'method' that has a choice 'expected' but declares no
    # fidelity is not touched; the declared parameter, whatever its name, is.
    monkeypatch.setitem(graph.classes, "ppp", Leveled)
    assert expected_overrides(graph) == {
        "weather.method": "expected",
        "ppp.level": "noise_free",
    }
