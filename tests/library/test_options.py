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
    (dict(speckle_size=50, speckle_range="1.5"), "speckle_range", 1.5),
    (dict(cost="CENSUS"), "cost", "census"),
    (dict(csw=True, tau="None"), "tau", math.inf), (dict(csw=True, tau=12), "tau", 12.0),
    (dict(csw=True, csw_rule="unique", csw_margin="20"), "csw_margin", 20),
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
        # tau, csw_margin, a range "auto" and penalties left to default are resolved to
        # the numbers used
        checked = params.check(name, value)
        if name not in ("tau", "csw_margin") and checked != "auto" and not (
                name in ("sgm_p1", "sgm_p2") and checked is None):
            assert result.settings[name] == checked, name


def test_the_config_is_one_frozen_typed_record_of_the_table():
    """resolve() returns a Config whose fields (and its stages' fields) are the option
    table's names, typed, and that can't be changed in place."""
    import dataclasses

    config = params.resolve(preset="accurate", dmax=20)
    fields = {f.name for f in dataclasses.fields(params.Config)} - {"stages", "given",
                                                                     "range_source"}
    stage_fields = {f.name for f in dataclasses.fields(params.Stages)}
    assert fields | stage_fields == set(params.OPTIONS)
    assert stage_fields == set(params.STAGE_NAMES)
    assert all(f.type for f in dataclasses.fields(params.Config))
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.dmax = 30
    assert config.as_dict()["dmax"] == 20 and config.as_dict()["lr_check"] == 2


def test_the_kernels_get_the_table_s_census_not_one_of_their_own():
    """--preset raw --cost census runs the table's census (once the kernels' own dense 5x5
    default ran silently); the kernels refuse a census without its window and pattern."""
    config = params.resolve(preset="raw", cost="census")
    assert (config.stages.census_window, config.stages.census_pattern) == \
        (params.DEFAULT_CENSUS_WINDOW, params.DEFAULT_CENSUS_PATTERN)
    image = np.zeros((9, 20), np.uint8)
    with pytest.raises(ValueError, match="census_window and census_pattern"):
        csw.kernels.match(image, image, engine="fast", window=3, dmin=0, dmax=4,
                          cost="census")
    with pytest.raises(ValueError, match="give csw_margin"):
        csw.kernels.match(image, image, engine="fast", window=3, dmin=0, dmax=4, cost="sad",
                          csw=True, tau=5, rule="unique")


@pytest.mark.parametrize("given, source", [
    ({}, "auto"), ({"preset": "paper"}, "default"), ({"dmax": 20}, "given"),
    ({"dmin": 2}, "auto"), ({"dmin": 2, "dmax": 30}, "given"), ({"dmax": "auto"}, "auto")])
def test_the_range_says_where_it_came_from(small_scene, given, source):
    result = csw.match(*small_scene[:2], **given)
    assert result.settings["range_source"] == source


def test_a_calibration_s_ndisp_sets_an_ungiven_dmax_only():
    from dataclasses import replace

    from csw.camera.calibration import given as calibration_given
    from csw.matching import disparity_range

    calibration = replace(calibration_given(focal=100, baseline=0.1), ndisp=33)
    config = disparity_range.decide(params.resolve(), 200, calibration)
    assert (config.dmin, config.dmax) == (0, 32)
    assert config.range_source.startswith("ndisp of")
    kept = disparity_range.decide(params.resolve(dmax=20), 200, calibration)
    assert (kept.dmax, kept.range_source) == (20, "given")


@pytest.mark.parametrize("name, value", [("tau", 5), ("csw_margin", 10)])
def test_options_that_need_csw_are_refused_without_it(name, value):
    with pytest.raises(params.OptionError, match="only with CSW on"):
        params.resolve(**{name: value})
    assert getattr(params.resolve(preset="accurate", csw=True, **{name: value}),
                   name) is not None


def test_bad_options_fail_at_construction_not_at_the_first_pair():
    """A Matcher checks its options when made (its docstring says so): a range whose
    dmin exceeds its dmax, or more threads than the option table allows, fail there,
    and csw.match with them fails the same way, at once."""
    with pytest.raises(params.OptionError, match=r"dmin \(20\) must not exceed dmax \(10\)"):
        csw.Matcher(dmin=20, dmax=10, pixels=None)
    with pytest.raises(params.OptionError, match=f"threads must be from 1 to "
                                                 f"{params.MAX_THREADS}"):
        csw.Matcher(threads=10**6, pixels=None)
    with pytest.raises(params.OptionError, match="threads"):
        csw.match(LEFT, RIGHT, dmax=8, threads=10**6)
    assert csw.Matcher(dmin=10, dmax=10, pixels=None).config.dmax == 10  # one disparity
