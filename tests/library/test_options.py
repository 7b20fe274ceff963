"""The library accepts what it documents, and refuses the rest with a ValueError.

csw.config.params.OPTIONS is the one table of options; csw.match, the CLI and the experiments
read it.  These tests call csw.match with the spellings its docstring and the CLI's help
give, and with random values of every kind.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import csw
from csw.config import params

LEFT = (np.arange(24 * 40).reshape(24, 40) * 37 % 251).astype(np.uint8)
RIGHT = np.roll(LEFT, -2, axis=1)


@pytest.mark.parametrize("given, name, value", [
    (dict(lr_check="off"), "lr_check", None), (dict(lr_check="3"), "lr_check", 3),
    (dict(uniqueness_ratio="off"), "uniqueness_ratio", None),
    (dict(texture_threshold="OFF"), "texture_threshold", None),
    (dict(median="3"), "median", 3), (dict(window=9.0), "window", 9),
    (dict(speckle_range="1.5"), "speckle_range", 1.5), (dict(cost="CENSUS"), "cost", "census"),
    (dict(csw=True, tau="None"), "tau", math.inf), (dict(csw=True, tau=12), "tau", 12.0),
    (dict(csw=True, csw_rule="unique", uniqueness="20"), "uniqueness", 20),
])
def test_documented_spellings_are_accepted(given, name, value):
    """The docstring's spellings ("off", numbers as text, any case) are read, not refused
    (csw.match(lr_check="off") once raised a TypeError from inside the pipeline)."""
    result = csw.match(LEFT, RIGHT, dmax=8, preset="raw", **given)
    assert result.settings[name] == value


def test_every_option_has_a_default_help_and_a_check():
    for name, option in params.OPTIONS.items():
        assert option.help, name
        assert option.check(option.default) == option.default or option.default is None


def test_the_default_preset_is_one_of_the_presets():
    assert params.DEFAULTS["preset"] in params.PRESETS
    for preset in params.PRESETS.values():
        for name, value in preset.items():
            assert params.OPTIONS[name].check(value) == value, name


GARBAGE = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=6),
                    st.sampled_from(["off", "auto", "none", "3", "7", "9.5", "-1", "1e9"]))


def values_for(name):
    """Valid values of an option, its documented spellings, and anything at all."""
    option = params.OPTIONS[name]
    valid = {
        "choice": st.sampled_from(option.choices or ("x",)),
        "int": st.sampled_from(option.choices) if option.choices else
        st.integers(int(option.low or 0), int(option.low or 0) + 12),
        "float": st.floats(0, 5),
        "bool": st.booleans(),
        "off_int": st.one_of(st.none(), st.just("off"), st.integers(0, 50)),
        "auto_int": st.one_of(st.none(), st.integers(1, 2)),
        "tau": st.one_of(st.none(), st.sampled_from(["auto", "none"]), st.floats(0, 500)),
        "int_auto": st.one_of(st.just("auto"), st.integers(-8, 30)),
    }[option.kind]
    return st.one_of(valid, GARBAGE)


# Options kept small so that every drawn match stays quick.
SMALL = {"window": st.one_of(st.sampled_from([1, 3, 5, 9, 41, 4, -3, "7", 2.5]), GARBAGE),
         "dmax": st.one_of(st.integers(-5, 45), st.just("auto"), GARBAGE),
         "dmin": st.one_of(st.integers(-10, 10), st.just("auto"), GARBAGE),
         "speckle_size": st.one_of(st.integers(0, 300), GARBAGE),
         "threads": st.one_of(st.none(), st.integers(-1, 3), GARBAGE)}


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.fixed_dictionaries({}, optional={name: SMALL.get(name, values_for(name))
                                           for name in params.OPTIONS}))
def test_any_option_values_give_a_result_or_a_value_error(options):
    try:
        result = csw.match(LEFT, RIGHT, **options)
    except ValueError:
        return
    assert result.disparity.shape == LEFT.shape and result.disparity.dtype == np.float32
    for name, value in options.items():
        # tau, uniqueness and a range "auto" are resolved to the numbers used
        if name not in ("tau", "uniqueness") and params.check(name, value) != "auto":
            assert result.settings[name] == params.check(name, value), name
