import math

import pytest

from csw.config.tau import parse_sweep, parse_tau, resolve_tau


@pytest.mark.parametrize("text, value", [("auto", "auto"), ("none", "none"), ("paper", "paper"),
                                         ("410", 410.0), (" 3.5 ", 3.5), (12, 12.0)])
def test_parse_tau(text, value):
    assert parse_tau(text) == value


@pytest.mark.parametrize("text", ["nan", "-1", "often", True])
def test_parse_tau_refuses(text):
    with pytest.raises(ValueError):
        parse_tau(text)


def test_resolve_tau_defaults_and_paper():
    assert resolve_tau(None, "unique") == (math.inf, "none")
    assert resolve_tau(None, "literal", plain_min_cost=lambda: [0, 10, 100]) == (10.0, "auto")
    assert resolve_tau("paper", "literal", paper_value=410) == (410.0, "paper")
    assert resolve_tau("paper", "literal", plain_min_cost=lambda: [0, 100])[1] == \
        "auto (no paper value)"
    assert resolve_tau("none", "literal") == (math.inf, "none")


def test_sweep_specs_and_their_bound():
    items = parse_sweep("0.5x,100:300:100,none")
    assert [(k, n) for _, k, n in items] == [("times", 0.5), ("abs", 100.0), ("abs", 200.0),
                                             ("abs", 300.0), ("none", None)]
    with pytest.raises(ValueError, match="more than 1000"):
        parse_sweep("0:1e9:1")  # would have built a billion-item list
    with pytest.raises(ValueError, match="a:b:step"):
        parse_sweep("5:1:0")
